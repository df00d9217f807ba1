"""The virtual healthy population at work: its subjects (device.sim.population) run through
the thesis's experiment and, later, the assessment battery, spread over processes, and
what comes of it (the population against the thesis's subject, the simulated normative
model).

May import core, device, app.trials and app.records.
"""
