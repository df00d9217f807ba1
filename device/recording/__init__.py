"""Recording a trial: the per-tick record, the shared-memory ring the loop pushes it into,
the recorder process that drains the ring, and the HDF5 trial-file writer.

May import core, device.errors and device.safety (fault codes in the records). Never the
loop, the simulator or the hardware: recording works the same whatever produced the
records.
"""
