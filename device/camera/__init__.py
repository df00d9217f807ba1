"""Video of a trial: capture stamped on the loop's monotonic clock, written beside the
trial file, for the pose estimation that turns pictures into joint angles.

May import core, device.errors and OpenCV (the only device package that does).
"""
