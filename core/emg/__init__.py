"""Surface EMG, the science (thesis chapter 5): cleaning, the RMS envelope, the maximum
voluntary contraction and its quality check, normalisation, the loop's time base
(`processing`, `mvc`), synthetic subjects made from known muscle activations
(`synthetic`), EMG-to-joint-torque models with their honest validation (`models`), and
the force on the handle their torques imply, scored against the sensor's (`force`).

numpy and scipy only, SI units (volts, seconds, N·m); activations and normalised
envelopes are fractions of MVC (1 = 100 % MVC), shown as percentages only on screen.
Filtering goes through core.signal's zero-lag filter.
"""
