"""The EMG tab's chooser of the source channel under each muscle: the channels by the names
the connected source declares (an LSL stream's channel labels, device.lsl.inlet), the names
the trial file keeps them under (app.emg.importing.channel_names), else EMG1, EMG2 …

Why: the chooser said EMG1, EMG2 … while the stream named its channels ("biceps_r",
"Sensor 3"), and the therapist had to count the stream's channels to find the muscle's.
"""

from __future__ import annotations

from PySide6.QtCore import Qt, Signal

from app.emg.importing import channel_names
from ui.fields import ComboBox

CHANNELS = 16
"""Channels offered before a source says its own: a Trigno base's sensors."""


class ChannelChooser(ComboBox):
    """One muscle's source channel, numbered from 1 (`value`, `setValue`, `valueChanged`,
    as the spin box it replaces), shown by the source's name for it."""

    valueChanged = Signal(int)

    def __init__(self) -> None:
        super().__init__()
        self.name_channels(())
        self.currentIndexChanged.connect(lambda index: self.valueChanged.emit(index + 1))

    def name_channels(self, declared) -> None:
        """Name the channels as a source declares them (`declared`, its labels: () when it
        names none); the channel chosen stays chosen. Channels past the declared ones keep
        their number: one chosen before the source connected is still there to see."""
        names = channel_names(declared, len(tuple(declared or ())))
        width = max(CHANNELS, len(names), self.count())
        shown = (*names, *channel_names((), width)[len(names):])
        chosen = self.currentIndex()
        self.blockSignals(True)  # the same channel: nothing changed for the muscle
        self.clear()
        for k, name in enumerate(shown):
            self.addItem(name)
            self.setItemData(k, f"the source's channel {k + 1}",
                             Qt.ItemDataRole.ToolTipRole)
        self.setCurrentIndex(max(chosen, 0))
        self.blockSignals(False)

    def value(self) -> int:
        return self.currentIndex() + 1

    def setValue(self, value: int) -> None:
        self.setCurrentIndex(value - 1)
