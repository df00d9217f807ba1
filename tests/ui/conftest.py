"""Each test file of the window leaves no window behind for the next file in its process.

Under pytest-xdist one worker runs many files in one QApplication. A window a module's
fixture built and never closed (or a plot awaiting deleteLater) stayed alive into the next
file, whose theme call re-polished it half torn down: a worker crashed in
QApplication.setStyle. At each file's end its top-level widgets are closed and deleted
before the next file starts.
"""

from __future__ import annotations

from unittest import mock

import pytest


@pytest.fixture(scope="module", autouse=True)
def _windows_closed_after_each_file():
    yield
    from PySide6.QtCore import QCoreApplication, QEvent
    from PySide6.QtWidgets import QApplication, QMessageBox

    app = QApplication.instance()
    if app is None:
        return
    # A console closed while a trial runs asks first; nobody is here to answer.
    with mock.patch.object(QMessageBox, "question",
                           return_value=QMessageBox.StandardButton.Yes):
        for widget in app.topLevelWidgets():
            widget.close()
            widget.deleteLater()
    QCoreApplication.sendPostedEvents(None, QEvent.Type.DeferredDelete)
    app.processEvents()
