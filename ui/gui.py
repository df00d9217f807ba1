"""Start the window: Qt, the theme, the data folder and registry, then the loop processes
once the window is on screen (so it appears in well under two seconds)."""

from __future__ import annotations

import gc
import logging
import signal
import sys
import time

log = logging.getLogger(__name__)


def run_gui(font_scale: float | None = None, lsl_outlet: bool = False) -> int:
    started = time.perf_counter()
    from PySide6.QtCore import QTimer
    from PySide6.QtWidgets import QApplication

    from app.records.datadir import locate_data_dir
    from app.records.logs import setup_logging
    from app.records.registry import open_registry
    from app.records.settings import load_settings
    from device.lsl.library import LIBLSL_LOG, log_liblsl_into
    from device.stopsignals import STOP_SIGNALS
    from ui import theme
    from ui.collector import WindowThreadCollector
    from ui.main_window import MainWindow

    settings = load_settings()
    data_dir = locate_data_dir(settings)
    data_dir.ensure_layout()
    # liblsl's errors beside the console's log, not on a terminal nobody reads
    log_liblsl_into(setup_logging(data_dir).parent / LIBLSL_LOG)
    app = QApplication.instance() or QApplication(sys.argv[:1])
    app.setApplicationName("Rehabilitation robot console")
    theme.apply_theme(app, font_scale or 1.0)
    collector = WindowThreadCollector(app)  # no cyclic collection off this thread
    collector.start()
    bridge = None
    if lsl_outlet:
        from device.lsl.outlet import RobotStateOutlet
        from ui.device_bridge import DeviceBridge

        bridge = DeviceBridge(lsl_outlet=RobotStateOutlet())
    window = MainWindow(open_registry(data_dir, standby=True), settings=settings,
                        bridge=bridge)
    window.show()

    def stop(number, _frame) -> None:
        # Ctrl+C, a service manager's SIGTERM or a closed terminal's SIGHUP: close as if by
        # the window's own button, without asking; a running trial stops as at a fault
        # naming the signal, is saved and recorded, and the loop processes end cleanly
        # (device.stopsignals). A second signal while closing changes nothing.
        if window.closing_by_signal:
            return
        window.closing_by_signal = True
        window.closing_signal = signal.Signals(number).name
        # from the event loop: the signal may have come in the middle of a repaint, and
        # closing there (which waits for the loop processes) crashed Qt's painter
        QTimer.singleShot(0, close)

    def close() -> None:
        window.close()
        app.quit()

    for number in STOP_SIGNALS:
        signal.signal(number, stop)
    wake = QTimer()
    wake.timeout.connect(lambda: None)  # gives Python a moment to run its signal handlers
    wake.start(200)
    QTimer.singleShot(0, lambda: log.info("window shown %.2f s after start",
                                          time.perf_counter() - started))
    QTimer.singleShot(50, window.start_device)
    QTimer.singleShot(100, window.finish_interrupted_trials)
    # Start-up objects never die: moving them out of the collector's reach keeps its
    # passes short (the progress query's p99 falls from ~70 to ~30 ms, bench/registry.py).
    QTimer.singleShot(1000, gc.freeze)
    return app.exec()
