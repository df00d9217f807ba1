"""Pose estimation of a recorded trial: its video through the pose detector
(device.camera.detector), the geometry of core.pose, and the result kept in the trial
file's `/pose` group (docs/data-format.md).

`offline` (a trial and its video to the pose group, with progress), `store` (writing and
reading the group), `synthetic` (a known camera over a simulated trial, for the tests and
bench/pose.py).
"""
