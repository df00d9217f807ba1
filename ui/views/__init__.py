"""The window's view models: what the tabs show, computed without Qt, so they can be
tested and reused without a display. The "Only ui imports Qt" contract covers them.
"""
