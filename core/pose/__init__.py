"""Pose from video: the geometry that turns keypoints seen by a camera into the subject's
joint angles on the robot's clock (section 2.4, section 3.4 and Table 3.4, Appendix A.5).

`keypoints` (one frame's arm keypoints, low visibility as gaps), `homography` (camera
image to the table plane, fitted robustly from the handle or from marked points, with its
residual in mm), `angles` (shoulder and elbow angles from table-plane keypoints in the arm's
convention, eq. 3.16, the shoulder's position and drift, the equation solver with the
camera's shoulder), `timebase` (video frames onto the trial's clock and its 2 ms samples,
gaps kept), `compare` (camera against solver, or either against reference angles: RMSE and
bias per joint, as Table 3.4), `pipeline` (all of it in order, after the detector). The
detector that finds keypoints in a picture is not
here (device.camera.detector); everything here works on its output.

May import numpy, scipy and the rest of core.
"""
