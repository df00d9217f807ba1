"""What researchers take away: a trial or a study as CSV/TSV with units, MATLAB .mat and
a BIDS-motion dataset, and the researcher's loader (`app.exports.loader`).

May import core, device, app.records and app.trials.
"""
