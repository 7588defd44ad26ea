"""argparse building blocks shared by every ``mdr-drive`` subcommand (those of installed packages too).

* :class:`Parser`: an ``ArgumentParser`` whose errors are one line (``prog: error: ...``, exit 2).
* :class:`HelpFormatter`: appends ``(default: X)`` to an option's help only when the help does
  not state its default already and X means something (not None, not a switch's False).
* :func:`run_command`: a command's work with one-line errors and a one-line Ctrl-C message.
* argparse ``type=`` functions that check a value or a path when the command line is read, before
  any work: integers in a range, input files and folders that must exist, output files and folders
  that must be creatable.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path


class HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """Help with each option's default once: added unless the help already says ``default``."""

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        meaningless = action.default is None or action.default is False or action.default == argparse.SUPPRESS
        if "default" in text or meaningless:  # (0.0 == False: compare by identity)
            return text
        if action.option_strings or action.nargs in (argparse.OPTIONAL, argparse.ZERO_OR_MORE):
            return f"{text} (default: %(default)s)"
        return text


class Parser(argparse.ArgumentParser):
    """``ArgumentParser`` with one-line errors: ``prog: error: message`` on stderr, exit code 2."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("formatter_class", HelpFormatter)
        super().__init__(*args, **kwargs)

    def error(self, message: str):  # noqa: D401  (argparse's hook)
        print(f"{self.prog}: error: {message}", file=sys.stderr)
        raise SystemExit(2)


def run_command(prog: str, work, interrupted: str) -> int:
    """Run ``work()`` for command ``prog``: 0; a ``ValueError`` as one line ``prog: error: ...``, 2;
    Ctrl-C as one line ``prog: interrupted; <interrupted>`` (what was kept, how to continue), 130."""
    try:
        work()
    except ValueError as e:
        print(f"{prog}: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"{prog}: interrupted; {interrupted}", file=sys.stderr)
        return 130
    return 0


def int_range(low: int, high: int | None = None):
    """argparse type: an integer in ``[low, high]`` (``high=None``: no upper bound)."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
        if value < low or (high is not None and value > high):
            raise argparse.ArgumentTypeError(f"{value} is outside the allowed range [{low}, {high or 'inf'}]")
        return value

    parse.__name__ = "integer"
    return parse


#: argparse type: an integer >= 1.
positive_int = int_range(1)


def _creatable(path: Path) -> str | None:
    """Why ``path`` cannot be created as a folder, or None if it can (it may exist already)."""
    if path.exists():
        if not path.is_dir():
            return f"'{path}' exists and is not a folder"
        return None if os.access(path, os.W_OK) else f"folder '{path}' is not writable"
    parent = path.parent
    while not parent.exists():
        parent = parent.parent
    if not parent.is_dir():
        return f"'{parent}' is not a folder"
    return None if os.access(parent, os.W_OK) else f"folder '{parent}' is not writable"


def output_dir(text: str) -> str:
    """argparse type: a folder that exists or can be created (it is created when written to)."""
    problem = _creatable(Path(text))
    if problem:
        raise argparse.ArgumentTypeError(problem)
    return text


def output_file(*suffixes: str):
    """argparse type: a file whose folder exists or can be created, with one of ``suffixes``."""

    def parse(text: str) -> str:
        path = Path(text)
        if suffixes and path.suffix.lower() not in suffixes:
            raise argparse.ArgumentTypeError(f"'{text}' must end in {' or '.join(suffixes)}")
        if path.is_dir():
            raise argparse.ArgumentTypeError(f"'{text}' is a folder, not a file")
        problem = _creatable(path.parent if str(path.parent) else Path("."))
        if problem:
            raise argparse.ArgumentTypeError(problem)
        return text

    parse.__name__ = "output file"
    return parse


def _existing(text: str, kind: str) -> Path:
    """``text`` as a path that exists and is a ``kind`` ("file" or "folder"), else ArgumentTypeError."""
    path = Path(text)
    if not path.exists():
        raise argparse.ArgumentTypeError(f"{kind} '{text}' does not exist")
    if not (path.is_file() if kind == "file" else path.is_dir()):
        raise argparse.ArgumentTypeError(f"'{text}' is not a {kind}")
    return path


def input_file(text: str) -> str:
    """argparse type: an existing file."""
    _existing(text, "file")
    return text


def folder_with(*names: str):
    """argparse type: an existing folder that holds every file in ``names``."""

    def parse(text: str) -> str:
        path = _existing(text, "folder")
        missing = [n for n in names if not (path / n).exists()]
        if missing:
            raise argparse.ArgumentTypeError(f"folder '{text}' has no {', '.join(missing)}")
        return text

    parse.__name__ = "folder"
    return parse
