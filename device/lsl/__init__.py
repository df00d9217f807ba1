"""The Lab Streaming Layer: liblsl loaded in one place (`library`), an inlet for any EMG
stream read in volts (`inlet`), and the robot's state and the trial's events as an outlet
(`outlet`) stamped on the loop's clock of each connection (`timeline`).

pylsl is imported only in `library`, when a stream is opened or looked for; the loop
process never loads it (the outlet runs on the window's device worker).
"""
