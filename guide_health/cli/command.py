"""What a sub-command is (options, computation, text) and the error rule every command shares."""
from __future__ import annotations

import argparse
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from guide_health.errors import InputError


@dataclass(frozen=True)
class Command:
    """One sub-command: ``add_arguments(parser)`` declares its options (the CLI adds ``--json``),
    ``run(args)`` parses them, calls the models/analysis and returns the result dict (None: nothing to
    print), ``format_text(result)`` renders it for a terminal (None: an indented key/value listing)."""

    add_arguments: Callable[[argparse.ArgumentParser], None]
    run: Callable[[argparse.Namespace], dict[str, Any] | None]
    format_text: Callable[[dict[str, Any]], str] | None = None


@contextmanager
def value_errors_as_input_errors() -> Iterator[None]:
    """A ValueError of a model (a value it cannot use) ends like bad input: InputError with its first line."""
    try:
        yield
    except InputError:
        raise
    except ValueError as exc:
        raise InputError(str(exc).splitlines()[0]) from exc


#: commands whose --out names a file (every other command's --out is a directory)
FILE_OUTPUTS = ("fleet:FLEET_PRIOR",)


def check_out_path(path, directory: bool = True) -> Path:
    """An output path a command can create or write: InputError (one line) when the path, or a part above
    it, is a file where a directory is needed (``--out EXISTING_FILE``, ``--out FILE/sub``)."""
    path = Path(path)
    for parent in path.parents:                     # nearest first: the first one that exists decides
        if parent.exists():
            if not parent.is_dir():
                raise InputError(f"--out {path}: {parent} is a file, not a directory; choose another --out")
            break
    if directory and path.exists() and not path.is_dir():
        raise InputError(f"--out {path} exists and is not a directory; remove it or choose another --out")
    if not directory and path.is_dir():
        raise InputError(f"--out {path} is a directory; give a file name")
    return path
