"""Where a verb writes (-o/--output), and how, so that nothing a user owns is ever lost.

One rule for every writing verb: `check_output` before any work, then `new_file` or
`new_folder` to write. An output is written under a temporary name beside its target (same
folder, so the rename is atomic) and renamed into place only once complete. --force replaces
only what the verb itself wrote: its own output file, or a folder it made and marked with
MARKER (which names the verb and the entries it wrote). Never an input of the same command,
never a folder holding anything else, never a directory where a file belongs: those are
refused with a typed error (exit code 3) whatever --force says. A write that fails (read-only
folder, full disk) is an OutputWriteError naming the path, and leaves no partial file.

>>> import tempfile
>>> folder = Path(tempfile.mkdtemp())
>>> with new_file(folder / "a.txt") as tmp:
...     _ = tmp.write_text("new")
>>> (folder / "a.txt").read_text(), sorted(p.name for p in folder.iterdir())
('new', ['a.txt'])
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import shutil
import zipfile
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

from spectratac.errors import SpectraTacError

#: The file a verb leaves in a folder it made: {"verb": ..., "entries": [...]} (JSON).
MARKER = ".spectratac-output"
#: Names shown when a folder that is not the verb's holds things.
SHOWN = 6

#: Which unmarked folders a verb still recognises as its own (e.g. made before the marker).
Recognise = Callable[[list[str]], bool]
#: Whether an existing file is of the kind a verb writes (so --force may replace it).
Kind = Callable[[Path], bool]
MCAP_MAGIC = b"\x89MCAP0\r\n"


def _zip_names(path: Path) -> list[str]:
    try:
        with zipfile.ZipFile(path) as z:
            return z.namelist()
    except (OSError, zipfile.BadZipFile, ValueError):
        return []


def is_mcap(path: Path) -> bool:
    """An MCAP file (a recording or a clip), complete or not."""
    with open(path, "rb") as f:
        return f.read(len(MCAP_MAGIC)) == MCAP_MAGIC


def is_npz(path: Path) -> bool:
    """A NumPy .npz archive (a dataset, a twin session)."""
    names = _zip_names(path)
    return bool(names) and all(n.endswith(".npy") for n in names)


def is_stac(path: Path) -> bool:
    """A model file (.stac: a zip holding meta.json)."""
    return "meta.json" in _zip_names(path)


KINDS: dict[Kind, str] = {
    is_mcap: "an MCAP recording",
    is_npz: "a NumPy .npz archive",
    is_stac: "a .stac model file",
}


class OutputExistsError(SpectraTacError):
    """The output file (or a non-empty output folder) is already there and --force was not
    given; nothing was written."""


class OutputIsInputError(OutputExistsError):
    """The output is (or holds) an input of the same command: refused even with --force."""


class OutputNotOursError(OutputExistsError):
    """--force was given for a file or folder the verb did not write: refused."""


class OutputWriteError(SpectraTacError):
    """Writing the output failed (read-only folder, full disk…); nothing partial is left."""


def _resolved(path: Path) -> Path:
    return Path(os.path.abspath(path)).resolve()


def _inside(path: Path, folder: Path) -> bool:
    return path == folder or folder in path.parents


def _listing(folder: Path) -> list[str]:
    return sorted(p.name + ("/" if p.is_dir() else "") for p in folder.iterdir())


def _shown(names: list[str]) -> str:
    more = f" and {len(names) - SHOWN} more" if len(names) > SHOWN else ""
    return ", ".join(names[:SHOWN]) + more


def marked_by(folder: Path) -> tuple[str | None, list[str]]:
    """(the verb, the entries it wrote) of a folder's marker, or (None, []) when unmarked."""
    try:
        mark = json.loads((folder / MARKER).read_text(encoding="utf-8")[:65536])
    except (OSError, ValueError, UnicodeDecodeError):
        return None, []
    if not isinstance(mark, dict) or not isinstance(mark.get("entries"), list):
        return None, []
    return str(mark.get("verb")), [str(e) for e in mark["entries"]]


def check_output(
    path: str | Path,
    force: bool,
    *,
    verb: str,
    inputs: Iterable[str | Path | None] = (),
    folder: bool = False,
    recognise: Recognise | None = None,
    kind: Kind | None = None,
) -> Path:
    """Refuse (typed, exit code 3) an output `verb` may not write; return it as a Path.

    Always refused: an output that is an input or holds one (`inputs`; a folder output also
    when it lies inside an input folder), a file output that is an existing directory, a
    folder output that is an existing file. Without `force`: an existing file or a folder
    holding anything. With `force`: a non-empty file only of the `kind` the verb writes; a
    non-empty folder only if marked as `verb`'s and holding nothing else, or if
    `recognise(entry names)` says it is the verb's own (folders made before the marker)."""
    out = Path(path)
    where = _resolved(out)
    for given in inputs:
        if given is None:
            continue
        source = _resolved(Path(given))
        if where == source or (folder and (_inside(source, where) or _inside(where, source))):
            raise OutputIsInputError(
                f"-o {out} {'is' if where == source else 'holds'} the input {given} of this "
                f"command; choose another -o/--output (even --force never replaces an input)"
            )
    if not (out.exists() or out.is_symlink()):
        return out
    if not folder:
        if out.is_dir():
            raise OutputNotOursError(
                f"-o {out} is a folder, but {verb} writes a file there; give a file name, "
                f"e.g. -o {out / ('out' + (out.suffix or ''))}"
            )
        if not force:
            raise OutputExistsError(
                f"file {out} already exists; pass --force to overwrite it, or choose "
                f"another -o/--output"
            )
        if not out.is_file():  # a device node, a pipe, a dangling link: never a verb's output
            raise OutputNotOursError(
                f"-o {out} is not a regular file {verb} could have written; choose another "
                f"-o/--output"
            )
        if kind is not None and out.stat().st_size and not kind(out):
            raise OutputNotOursError(
                f"--force replaces only a file {verb} wrote, and {out} is not one: it is not "
                f"{KINDS.get(kind, 'of that kind')}; choose another -o/--output, or move that "
                f"file away first"
            )
        return out
    if not out.is_dir() or out.is_symlink():
        raise OutputNotOursError(
            f"-o {out} is a file, but {verb} writes a folder there; choose another "
            f"-o/--output (--force replaces only a folder {verb} made)"
        )
    names = _listing(out)
    if not names:
        return out
    if not force:
        raise OutputExistsError(
            f"folder {out} already exists; pass --force to replace it (if {verb} wrote it), "
            f"or choose another -o/--output; it holds {_shown(names)}"
        )
    if not is_own_folder(out, verb, recognise):
        mark, entries = marked_by(out)
        others = [n for n in names if n.rstrip("/") not in entries and n != MARKER]
        why = (
            f"it was made by `spectratac {mark}`"
            if mark not in (None, verb)
            else f"it holds what {verb} did not write: {_shown(others)}"
            if mark == verb
            else f"it holds {_shown(names)}, and is not marked ({MARKER}) as a folder {verb} made"
        )
        raise OutputNotOursError(
            f"--force replaces only a folder {verb} made, and {out} is not one: {why}; "
            f"choose another -o/--output, or move those files away first"
        )
    return out


def is_own_folder(folder: Path, verb: str, recognise: Recognise | None = None) -> bool:
    """Whether `folder` holds only what `verb` wrote there (its marker says so, or
    `recognise` knows the verb's own file set)."""
    names = [n.rstrip("/") for n in _listing(folder)]
    mark, entries = marked_by(folder)
    if mark == verb:
        return all(n in entries or n == MARKER for n in names)
    return mark is None and recognise is not None and recognise(names)


@contextlib.contextmanager
def writing(path: Path, temporary: Path | None = None) -> Iterator[None]:
    """OSError while writing `path` as OutputWriteError saying what to do; a typed error
    naming the `temporary` name is said again naming `path` (what the user gave)."""
    try:
        yield
    except SpectraTacError as exc:
        text = str(exc)
        if temporary is None or str(temporary) not in text or isinstance(exc, OutputExistsError):
            raise
        try:
            renamed = type(exc)(text.replace(str(temporary), str(path)))
        except TypeError:  # an error type made of more than a message: as it is
            raise exc from None
        raise renamed from None
    except OSError as exc:
        if exc.errno in (errno.ENOSPC, errno.EDQUOT):
            what = "the disk is full"
            todo = "free some space or choose another -o/--output"
        elif isinstance(exc, PermissionError) or exc.errno == errno.EROFS:
            what = "the folder is not writable"
            todo = "choose a folder you may write to with -o/--output"
        else:
            what, todo = str(exc.strerror or exc), "choose another -o/--output"
        raise OutputWriteError(f"cannot write {path}: {what} ({exc}); {todo}") from None


def temporary_name(path: Path, kind: str = "partial") -> Path:
    """A hidden name beside `path` (same folder: renames are atomic), keeping its suffix."""
    return path.with_name(f".{path.stem}.{kind}-{os.getpid()}{path.suffix}")


@contextlib.contextmanager
def new_file(path: str | Path) -> Iterator[Path]:
    """Write a file under a temporary name beside `path` (the caller writes the yielded
    path), renamed onto `path` once the block ends without error; the temporary name is
    removed on any error, and OSErrors become OutputWriteError."""
    final = Path(path)
    tmp = temporary_name(final)
    with writing(final, tmp):
        try:
            yield tmp
            os.replace(tmp, final)
        finally:
            with contextlib.suppress(OSError):
                tmp.unlink()


@contextlib.contextmanager
def new_folder(path: str | Path, verb: str, recognise: Recognise | None = None) -> Iterator[Path]:
    """Write a folder: the yielded path (not yet existing, named like `path`, in a hidden
    folder beside it) is filled by the caller; once the block ends without error it is
    marked as `verb`'s and renamed onto `path`. A folder already at `path` (checked by
    check_output) is replaced only if it still holds only what `verb` wrote; nothing partial
    is left on any error, and OSErrors become OutputWriteError."""
    final = Path(path)
    hidden = final.with_name(f".{final.name}.partial-{os.getpid()}")
    staged = hidden / final.name
    old = final.with_name(f".{final.name}.old-{os.getpid()}")
    with writing(final, staged):
        try:
            hidden.mkdir(parents=True, exist_ok=True)
            yield staged
            staged.mkdir(exist_ok=True)  # a verb that wrote nothing still makes its folder
            entries = sorted(p.name for p in staged.iterdir() if p.name != MARKER)
            (staged / MARKER).write_text(json.dumps({"verb": verb, "entries": entries}) + "\n")
            if final.is_dir() and any(final.iterdir()):
                if not is_own_folder(final, verb, recognise):  # something came in meanwhile
                    raise OutputNotOursError(
                        f"{final} changed while {verb} ran and now holds files it did not "
                        f"write; the new output is kept in {staged}"
                    )
                os.rename(final, old)
            elif final.is_dir():
                final.rmdir()
            os.rename(staged, final)
            shutil.rmtree(old, ignore_errors=True)
        except OutputNotOursError:
            raise
        except BaseException:
            shutil.rmtree(hidden, ignore_errors=True)
            if old.exists() and not final.exists():
                os.rename(old, final)  # put the user's previous output back
            raise
        with contextlib.suppress(OSError):
            hidden.rmdir()


#: URL schemes whose rest names a file or folder the command reads.
FILE_SCHEMES = ("csv", "rosbag", "file")


def url_input(url: str | None) -> str | None:
    """The file or folder a reader URL reads (csv://FILE, rosbag://BAG?topic=…), else None.

    >>> url_input("rosbag://bags/s1?topic=/ft"), url_input("netft://192.168.1.1")
    ('bags/s1', None)
    """
    if url is None or "://" not in url:
        return None
    scheme, rest = url.split("://", 1)
    return rest.split("?", 1)[0] or None if scheme in FILE_SCHEMES else None
