"""Surface EMG in the clinic's work: importing a recording into a trial on the trial's clock
(`importing`), the session's MVC per muscle with its quality check and the MVC-normalised
envelopes on the trial's ticks (`session`), and synthetic subjects made by virtual patients
for the tests and the models (`subjects`)."""
