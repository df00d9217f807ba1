"""Session plans at the console: the built-in templates (resources/plans), the runner
that carries a plan out block by block (a Qt-free state machine), the plan's state the
patient's screen reads, and the dose a run delivered (from the registry and the trial
files)."""
