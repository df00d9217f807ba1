"""The simulated robot: the thesis robot with a virtual patient on its handle, the
patients themselves, the simulated sensors, and fault injection for any backend.

`simulator` is the backend (SimulatorBackend); `physics` its per-tick kernels (the
coupled dynamics with the patient's torque, the integrator, the sensors, read, write,
reset); `plant` what it simulates (the ideal plant, the controller's model, or a
realistic one drawn around it); `patients` the Patient protocol and the virtual patients
(VirtualPatient, make_patient); `patient_torque` a virtual patient's torque as a kernel;
`learning` a patient's trial-to-trial adaptation (learning and slacking); `holdtasks`
what a patient does in the tasks the robot leads (pushing up to the line, matching a
point the robot took the hand to); `sensors` the
force sensor's model; `faultinjection` FaultInjectingBackend, which wraps any backend.

May import core, device.backend, device.errors, and device.safety's fault codes (fault
injection); device.compiled only lazily, when a simulator is built compiled. Never
device.hardware (a simulation never touches a vendor API), device.loop or
device.recording.
"""
