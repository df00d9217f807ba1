"""The Instructions tab (thesis Fig. A.1): how to run a session, in plain words.

The text lives in resources/instructions.md so the clinic can reword it without
touching code; it is shown as rendered Markdown, scaled with the window's font.
"""

from __future__ import annotations

from pathlib import Path

from PySide6.QtWidgets import QTextBrowser, QVBoxLayout, QWidget

INSTRUCTIONS_PATH = Path(__file__).resolve().parents[2] / "resources" / "instructions.md"


class InstructionsTab(QWidget):
    def __init__(self, path: Path = INSTRUCTIONS_PATH, parent=None) -> None:
        super().__init__(parent)
        self.browser = QTextBrowser()
        self.browser.setOpenExternalLinks(False)
        self.browser.setAccessibleName("Instructions")
        try:
            text = path.read_text(encoding="utf-8")
        except OSError as exc:
            text = (f"# Instructions missing\n\nThe instructions file {path} cannot be read "
                    f"({exc.strerror or exc}). Reinstall the console or restore the file.")
        self.browser.setMarkdown(text)
        # Long lines are hard to follow: keep the text to a readable column.
        self.browser.document().setDocumentMargin(24)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(self.browser)

    def plain_text(self) -> str:
        return self.browser.toPlainText()
