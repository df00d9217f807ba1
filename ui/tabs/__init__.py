"""The console's tabs, one module each, in the order of the thesis's GUI (Appendix A).

The tabs that draw a trial follow the `ViewTab` protocol: the window calls
`show_view(view)` on the visible one from its 30–60 Hz timer while a trial runs
(and once on each when a replay loads), and `set_cursor(t)` on all of them when
the replay's slider moves. The Report tab follows the view too, once per trial: the
window gives it the replayed trial (or the live trial's registered report) when it is
shown or a replay loads. The others (instructions, registration, parameters, video,
replay) have their own signals and methods.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

from ui.tabs.angles import AnglesTab
from ui.tabs.emg import EmgTab
from ui.tabs.force import ForceTab
from ui.tabs.instructions import InstructionsTab
from ui.tabs.parameters import BackendChoice, ParametersTab
from ui.tabs.progress import ProgressTab
from ui.tabs.registration import RegistrationTab
from ui.tabs.replay import ReplayTab
from ui.tabs.report import ReportTab
from ui.tabs.torques import TorquesTab
from ui.tabs.trajectory import TrajectoryTab
from ui.tabs.video import VideoTab
from ui.views.trialview import TrialView


@runtime_checkable
class ViewTab(Protocol):
    def show_view(self, view: TrialView) -> None: ...

    def set_cursor(self, t: float | None) -> None: ...


# (title on the tab, class): the names resources/instructions.md uses.
TABS = (
    ("Instructions", InstructionsTab),
    ("Registration", RegistrationTab),
    ("Parameters", ParametersTab),
    ("Trajectory", TrajectoryTab),
    ("Force", ForceTab),
    ("Joint angles", AnglesTab),
    ("Joint torques", TorquesTab),
    ("EMG", EmgTab),
    ("Video", VideoTab),
    ("Report", ReportTab),
    ("Progress", ProgressTab),
    ("Replay", ReplayTab),
)
VIEW_TABS = (TrajectoryTab, ForceTab, AnglesTab, TorquesTab, EmgTab)

__all__ = [
    "TABS",
    "VIEW_TABS",
    "AnglesTab",
    "BackendChoice",
    "EmgTab",
    "ForceTab",
    "InstructionsTab",
    "ParametersTab",
    "ProgressTab",
    "RegistrationTab",
    "ReplayTab",
    "ReportTab",
    "TorquesTab",
    "TrajectoryTab",
    "VideoTab",
    "ViewTab",
]
