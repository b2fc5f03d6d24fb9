"""What the dashboard runs in each page as it connects: scripts sent to one browser through
viser's `RunJavascriptMessage` (the message viser itself uses to load plotly.js; viser 1.1's page
runs it with `new Function` at its next frame), and the page's own style.

`STOP_NEVER_COVERED`: a dialog (viser's modal: the throw's confirmation) covers the page with an
overlay until the server's message that closes it is handled, which a page rendering in software
does a frame later, and frames are slow there: a Stop pressed at once after *Throw now*, in the
throw's first second, landed on that overlay and was lost. The overlay and the box that centres
the dialog let clicks through (the dialog's own content still takes them), so that Stop is never
covered; the other buttons stay reachable behind a dialog too, and each click is still checked on
the server (`Dashboard._accept`).
"""

from __future__ import annotations

import json

import viser
from viser import _messages

#: The page's style: a dialog's overlay never takes a click (module docstring).
PAGE_STYLE = (
    ".mantine-Modal-overlay, .mantine-Modal-inner { pointer-events: none; }"
    " .mantine-Modal-content { pointer-events: auto; }"
)
#: The script that puts `PAGE_STYLE` in the page once.
STOP_NEVER_COVERED = (
    "if (!document.getElementById('wiithrow-style')) { const e = document.createElement('style');"
    f" e.id = 'wiithrow-style'; e.textContent = {json.dumps(PAGE_STYLE)}; document.head.appendChild(e); }}"
)


def run_in_page(client: viser.ClientHandle, source: str) -> None:
    """Run the script `source` in `client`'s page (at its next frame)."""
    client._websock_connection.queue_message(_messages.RunJavascriptMessage(source=source))  # viser 1.1 (private)
