"""fairaudit.base.progress: a bar on stderr where it is asked for (``enabled``, or a ``progress_shown`` block) and
stderr is a terminal; nothing otherwise, and nothing without tqdm."""

from __future__ import annotations

import io
import sys

import pytest
from _terminal import on_terminal

from fairaudit.base.progress import progress_bar, progress_shown


def test_a_bar_is_drawn_on_a_terminal_and_cleared_when_closed(monkeypatch):
    terminal = on_terminal(monkeypatch)
    with progress_bar(3, "queries", True, unit="query") as bar:
        assert not bar.disable
        bar.update(1)
    drawn = terminal.getvalue()
    assert drawn.startswith("\rqueries:   0%|          | 0/3 [00:00<?, ?query/s]")
    assert drawn.rsplit("\r", 2)[-2].strip() == ""  # (leave=False: the line is blanked)


def test_no_bar_where_stderr_is_not_a_terminal(monkeypatch):
    stream = io.StringIO()
    monkeypatch.setattr(sys, "stderr", stream)
    with progress_bar(3, "queries", True) as bar:
        bar.update(1)
    assert bar.disable and stream.getvalue() == ""


def test_enabled_none_follows_the_enclosing_progress_shown_block(monkeypatch):
    terminal = on_terminal(monkeypatch)
    assert progress_bar(3, "outside").disable
    with progress_shown():
        with progress_bar(3, "inside") as inside:
            assert not inside.disable
        with progress_shown(False):
            assert progress_bar(3, "turned off").disable
    with pytest.raises(KeyboardInterrupt), progress_shown():
        raise KeyboardInterrupt
    assert progress_bar(3, "after").disable  # (the block is left however it ends)
    assert "inside: " in terminal.getvalue() and "outside" not in terminal.getvalue()
    assert "turned off" not in terminal.getvalue() and "after" not in terminal.getvalue()


def test_no_bar_without_tqdm(monkeypatch):
    terminal = on_terminal(monkeypatch)
    monkeypatch.setitem(sys.modules, "tqdm", None)  # (import tqdm raises ImportError)
    bar = progress_bar(3, "queries", True)
    bar.update(1)
    bar.set_postfix_str("best 1 nats")
    bar.close()
    assert bar.disable and terminal.getvalue() == ""


def test_an_empty_loop_has_no_bar(monkeypatch):
    terminal = on_terminal(monkeypatch)
    assert progress_bar(0, "queries", True).disable and terminal.getvalue() == ""
