"""``dynderive build``: regenerate the outputs of many robot files, only where inputs changed.

A small manifest in the output directory records, per robot file, a content hash of its
inputs (the robot file, the templates in use, the dynderive version and the output kinds)
and of each output it produced. A robot whose inputs and outputs match is up to date and is
not derived again. ``--check`` writes nothing and trusts no manifest: it regenerates every
output in memory and reports each one that is missing or whose bytes differ from the file.

Records are keyed by the robot file's real path relative to the output directory, so the
same files are up to date however the folder is named on the command line (``robots``,
``./robots``, an absolute path, ``.`` from inside it). Two robot files with the same robot
name (hence the same output files) are refused before anything is built: in one run, or
across runs when the manifest says another file that still has that name wrote them. A
manifest or record that is not what dynderive writes (a merge conflict, a hand edit) counts
as absent, with a note; so does a manifest that is a symbolic link, which is never read or
written through (the link itself is replaced). The manifest is read, merged and replaced
under an exclusive lock (``flock`` on the output folder itself, so no lock file is left
behind), so concurrent builds into one directory keep every record.

A robot's outputs agree after every run: a PDF that could not be made removes the robot's
earlier PDF (the new ``.tex`` and LaTeX's log are written), a PDF or extension that is made
removes the log of an earlier failure. Records of robot files that no longer exist are kept
while their outputs are in the output directory: those outputs are reported as orphaned
(``--check`` fails on them) until ``prune`` removes them with the record: only those that
are still what ``build`` wrote (``prune.py`` says what that means).

An interrupt (SIGINT, SIGTERM) of a parallel build cancels the robots not started and stops
the workers at once (they hold nothing but outputs in memory), then exits as any other.
"""

from __future__ import annotations

import hashlib
import json
import multiprocessing
import os
import re
import signal
import stat
import sysconfig
import time
from collections.abc import Callable, Iterator
from concurrent.futures import ProcessPoolExecutor
from contextlib import contextmanager, suppress
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import DynderiveError, InputError, LatexError, OutputError, Problem, ToolMissingError
from ..render.targets import COLUMNS as _TARGETS  # the code targets, in the order of their options

try:
    import fcntl
except ImportError:  # pragma: no cover - not POSIX: builds are not serialized
    fcntl = None  # type: ignore[assignment]

MANIFEST = ".dynderive-build.json"
#: The lock file of earlier versions (and of file systems that cannot lock a folder).
LOCK = ".dynderive-build.lock"
SUFFIXES = (".yaml", ".yml", ".urdf", ".xml")
#: The compiled extension's file name ends with this Python's suffix for extensions.
EXTENSION_SUFFIX = sysconfig.get_config_var("EXT_SUFFIX") or ".so"
#: Every output file a robot named ``name`` can have (``.log``: a sheet LaTeX could not
#: compile), the code targets' among them (a MATLAB package ``+<name>/``: its parameters.m)
OUTPUT_NAMES = ("{}.tex", "{}.pdf", *(pattern for target in _TARGETS for pattern in target.outputs), "{}.json",
                "{}.log", "{}.html")
TEMPLATES = {"latex": ["sheet.tex.j2", "preamble.tex.j2"],
             "pdf": ["sheet.tex.j2", "preamble.tex.j2"],
             **{target.kind: list(target.templates) for target in _TARGETS},
             "json": [], "html": ["html/sheet.html.j2"],
             "floating_base": []}   # not an output: --floating-base, part of the inputs (so is digits:N, --digits)


@dataclass
class Outcome:
    source: str
    status: str                      # built, up to date, failed, current, differs
    seconds: float = 0.0
    message: str = ""
    outputs: dict[str, str] = field(default_factory=dict)   # file name -> sha256
    problems: list[str] = field(default_factory=list)        # --check: missing/differing files
    #: the PDF's pages, LaTeX's seconds and its widest overfull line (pt), when a PDF was built
    sheet: dict[str, float] = field(default_factory=dict)


def discover(paths: list[Path]) -> list[Path]:
    """Robot files under ``paths`` (files as given, folders searched; extensions in any case,
    ``ARM.URDF`` too), in a stable order."""
    found: list[Path] = []
    problems: list[Problem] = []
    for path in paths:
        if path.is_dir():
            inside = sorted(p for p in path.rglob("*") if p.suffix.lower() in SUFFIXES and p.is_file())
            if not inside:   # a job pointed at the wrong folder must not go green
                problems.append(Problem(str(path), 1, 1, "no robot files in this folder (" +
                                        ", ".join(f"*{suffix}" for suffix in SUFFIXES) + ", in any subfolder)"))
            found += inside
        elif path.is_file():
            found.append(path)
        else:
            problems.append(Problem(str(path), 1, 1, "no such file or directory"))
    if problems:
        raise InputError(problems)
    seen: set[Path] = set()
    return [p for p in found if not (p.resolve() in seen or seen.add(p.resolve()))]  # type: ignore[func-returns-value]


def robot_name(source: Path) -> tuple[str, int, int] | None:
    """The name a robot file's outputs are called by, and where it is written (1-based line
    and column of the ``name:`` value, or of the URDF ``<robot name>`` attribute's value).

    ``None`` if the file cannot be read that far; building it will report why.
    """
    from ..input.loader import load_document, read_text
    from ..input.sources import kind_of

    try:
        kind = kind_of(source)
        if kind in ("urdf", "mjcf"):
            from ..input.urdf import _parse_xml, identifier

            text = read_text(source)
            root = _parse_xml(text, str(source))
            tag, attribute = ("robot", "name") if kind == "urdf" else ("mujoco", "model")
            if root.tag != tag:
                return None
            where = _xml_name_position(text, root.line, root.column, tag, attribute)
            if kind == "mjcf":   # the reader's rule: <mujoco model>, else the file's stem
                from ..input.mjcf_tree import robot_identifier

                return (robot_identifier(root.attrib.get("model") or source.stem), *where)
            return (identifier(root.attrib.get(attribute, "robot") or "robot"), *where)
        doc = load_document(source)
    except DynderiveError:
        return None
    if not isinstance(doc.data, dict) or not isinstance(doc.data.get("name"), str):
        return None
    return (doc.data["name"], *doc.where(("name",)))


def _xml_name_position(text: str, line: int, column: int, tag: str, attribute: str) -> tuple[int, int]:
    """Position of the value of the element's name attribute (``<robot name>``, ``<mujoco
    model>``), the element starting at (line, column)."""
    start = sum(len(row) + 1 for row in text.split("\n")[: line - 1])
    match = re.compile(rf"<{tag}\b[^>]*?\s{attribute}\s*=\s*[\"']").search(text, start)
    if match is None:
        return line, column
    offset = match.end()
    return text.count("\n", 0, offset) + 1, offset - text.rfind("\n", 0, offset)


def check_names(sources: list[Path]) -> dict[Path, tuple[str, int, int]]:
    """Refuse robot files whose outputs would overwrite each other's: one problem per later
    file. Returns each readable file's robot name and its position."""
    owners: dict[str, Path] = {}
    names: dict[Path, tuple[str, int, int]] = {}
    problems: list[Problem] = []
    for source in sources:
        if (found := robot_name(source)) is None:
            continue
        names[source] = found
        name, line, column = found
        if name in owners:
            problems.append(Problem(str(source), line, column, f"robot name '{name}' is also used by "
                                    f"{owners[name]} (outputs would overwrite each other)"))
        else:
            owners[name] = source
    if problems:
        raise InputError(problems)
    return names


def check_previous_owners(names: dict[Path, tuple[str, int, int]], out: Path, manifest: dict[str, dict]) -> None:
    """Refuse a robot file whose outputs another robot file wrote into ``out`` in an earlier
    run (the manifest says which), while that file still exists and still has that name."""
    problems: list[Problem] = []
    for source, (name, line, column) in names.items():
        key = manifest_key(source, out)
        files = {pattern.format(name) for pattern in OUTPUT_NAMES}
        for other, record in manifest.items():
            if other == key or not files & set(record["outputs"]):
                continue
            previous = out.resolve() / other
            if previous.is_file() and (robot_name(previous) or ("",))[0] == name:
                shown = os.path.relpath(previous.resolve())
                problems.append(Problem(str(source), line, column, f"robot name '{name}' is also used by {shown}, "
                                        f"whose outputs are in {out} (outputs would overwrite each other; rename "
                                        "one robot or build it into another --out)"))
                break
    if problems:
        raise InputError(problems)


def manifest_key(source: Path, out: Path) -> str:
    """The manifest's name for ``source``: its real path relative to the output directory's."""
    return Path(os.path.relpath(source.resolve(), out.resolve())).as_posix()


def input_key(source: Path, kinds: tuple[str, ...], template_dir: Path | None) -> str:
    from .._version import __version__
    from ..render.environment import templates_in_use

    digest = hashlib.sha256()
    digest.update(f"dynderive {__version__} {engine_fingerprint()}\n{','.join(kinds)}\n".encode())
    for target in _TARGETS:   # the compiled bytes depend on the compiler, Python and NumPy too
        if target.kind in kinds and target.fingerprint:
            digest.update(target.fingerprint().encode())
    try:
        digest.update(source.read_bytes())
    except OSError:
        return ""   # never up to date: building it reports why it cannot be read
    names = sorted({name for kind in kinds for name in TEMPLATES.get(kind, [])})   # digits:N: none
    for name, template in templates_in_use(names, template_dir):   # with what they include
        try:
            digest.update(name.encode() + b"\0" + template.read_bytes() + b"\0")
        except OSError:
            return ""
    return digest.hexdigest()


def engine_fingerprint() -> str:
    """Hash of dynderive's own source: an engine change invalidates every manifest record."""
    digest = hashlib.sha256()
    package = Path(__file__).resolve().parents[1]   # the dynderive package
    for path in sorted(package.rglob("*.py")):
        digest.update(path.relative_to(package).as_posix().encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()[:16]


def render_outputs(source: str, kinds: tuple[str, ...], template_dir: str | None,
                   sheet: dict[str, float] | None = None,
                   ) -> tuple[dict[str, bytes], LatexError | ToolMissingError | None, str]:
    """Every requested output of one robot file, in memory (runs in a worker process), the
    PDF's failure if any (as ``solve.sheet_files`` gives it: LaTeX's log instead of the PDF),
    and the robot's name; with a PDF, ``sheet`` receives its pages, LaTeX's seconds and the
    widest overfull line (pt)."""
    from .. import derive, load_robot
    from .solve import output_wants, sheet_files, target_files

    floating_base = "floating_base" in kinds and source.lower().endswith(".urdf")   # URDF files only
    digits = next((int(kind.split(":")[1]) for kind in kinds if kind.startswith("digits:")), None)   # --digits
    symbolic = next((kind.partition(":")[2] for kind in kinds if kind.startswith("symbolic:")), None)
    symbolic = symbolic if source.lower().endswith(".urdf") else None   # --symbolic: URDF files only
    robot = load_robot(source, size_limits=True, floating_base=floating_base, symbolic=symbolic)
    derivation = derive(robot, wants=output_wants(kinds))
    sheets, failed = sheet_files(derivation, kinds, template_dir, digits=digits, sheet=sheet)
    files = {file: data for file, data in sheets.items() if not file.endswith((".json", ".html"))}   # the sheet
    files |= target_files(derivation, kinds, template_dir)[0]   # then the code, the JSON and the page
    files |= {file: sheets[file] for file in (f"{robot.name}.json", f"{robot.name}.html") if file in sheets}
    return files, failed, robot.name


#: (outputs, or None when nothing could be rendered; the error, if any, naming the robot file;
#: seconds; the sheet's numbers; the robot's name, "" when not known)
_Result = tuple[dict[str, bytes] | None, str, float, dict[str, float], str]


def _work(source: str, kinds: tuple[str, ...], template_dir: str | None, out: str | None) -> _Result:
    """``render_outputs`` of one robot, timed, its errors as text that names the robot file
    (a positioned input error names it already); ``out``: where a failed sheet's .tex and
    log will be (None: they will not be written)."""
    from ..render.environment import TemplateProblem
    from .solve import failure_text

    global _BUSY
    start = time.monotonic()
    sheet: dict[str, float] = {}
    files, error, name = None, "", ""
    _BUSY = True
    try:
        files, failed, name = render_outputs(source, kinds, template_dir, sheet)
    except _Stopped:   # in a worker told to stop: what the robot's work held is cleaned up by now
        os._exit(130)
    except TemplateProblem:
        raise   # a user's template is at fault: every robot would fail alike (exit 2)
    except InputError as exc:
        error = str(exc)
    except DynderiveError as exc:
        error = f"{source}: {exc}"
    except Exception as exc:  # an internal error in one robot must not stop the others
        error = f"{source}: internal error: {type(exc).__name__}: {exc}"
    else:
        if failed is not None:
            error = f"{source}: {str(failed) if out is None else failure_text(Path(out), name, failed)}"
    finally:
        _BUSY = False
    return files, error, time.monotonic() - start, sheet, name


def _parallel(pending: list[tuple[Path, str]], kinds: tuple[str, ...], templates: str | None, folder: str | None,
              jobs: int) -> list[tuple[Path, str, _Result]]:
    """``_work`` of every pending robot in ``jobs`` worker processes. An interrupt or a
    user's template error stops it at once: the robots not started are cancelled and the
    workers terminated (their work is in memory only), not waited for."""
    # forkserver: fresh workers, never a fork of a process whose threads (JAX's, a caller's)
    # hold locks; Python 3.14's default on Linux
    context = multiprocessing.get_context("forkserver")
    pool = ProcessPoolExecutor(max_workers=min(jobs, len(pending)), mp_context=context, initializer=_worker_signals)
    try:
        futures = [(s, k, pool.submit(_work, str(s), kinds, templates, folder)) for s, k in pending]
        results = [(s, k, f.result()) for s, k, f in futures]
    except BaseException:
        _stop(pool)
        raise
    pool.shutdown()
    return results


def _stop(pool: ProcessPoolExecutor) -> None:
    """Cancel the pool's queued work and end its workers now (SIGTERM, then SIGKILL for one
    that has not ended within a second)."""
    workers = list((getattr(pool, "_processes", None) or {}).values())   # no public handle before 3.14
    pool.shutdown(wait=False, cancel_futures=True)
    for worker in workers:
        with suppress(Exception):
            worker.terminate()
    for worker in workers:
        with suppress(Exception):
            worker.join(timeout=1.0)
            if worker.is_alive():
                worker.kill()
                worker.join(timeout=1.0)


#: In a worker: whether it is building a robot (a SIGTERM then unwinds it, so that LaTeX's
#: temporary folder and process go, before it exits).
_BUSY = False


class _Stopped(BaseException):
    """A worker was told to stop (SIGTERM) while building a robot."""


def _worker_signals() -> None:
    """A worker's signals: SIGINT (a terminal's Ctrl-C reaches the whole process group) is
    left to the parent, which stops the workers; SIGTERM ends the worker."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, _worker_stop)


def _worker_stop(signum: int, frame: object) -> None:
    if _BUSY:
        raise _Stopped
    os._exit(130)


def _sha(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def load_manifest(out: Path, note: Callable[[str], None] | None = None) -> dict[str, dict]:
    """The manifest's well-formed records; anything else counts as absent (``note`` says so)."""
    path = out / MANIFEST
    say = note or (lambda text: None)
    if path.is_symlink():
        say(f"note: {path} is a symbolic link, not a build manifest: it is not read, and a build replaces "
            "the link itself (what it points to is left alone)")
        return {}
    try:
        document = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        return {}
    except (OSError, ValueError) as exc:
        say(f"note: {path} is not a build manifest ({exc}); every robot is built again and the manifest replaced")
        return {}
    robots = document.get("robots") if isinstance(document, dict) else None
    if not isinstance(robots, dict):
        say(f"note: {path} is not a build manifest (no 'robots' mapping); every robot is built again "
            "and the manifest replaced")
        return {}
    kept = {name: record for name, record in robots.items() if _well_formed(record)}
    for name in robots.keys() - kept.keys():
        say(f"note: {path}: the record of {name} is malformed and ignored (it is built again)")
    return kept


def _well_formed(record: object) -> bool:
    """A record as ``build`` writes it: a key, the outputs' file names and hashes, the sheet's numbers."""
    if not isinstance(record, dict) or not isinstance(record.get("key"), str):
        return False
    outputs, sheet = record.get("outputs"), record.get("sheet", {})
    return (isinstance(outputs, dict) and bool(outputs) and isinstance(sheet, dict)
            and all(isinstance(f, str) and isinstance(h, str) and _output_name(f) for f, h in outputs.items())
            and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in sheet.values()))


def _output_name(file: str) -> bool:
    """A name ``build`` gives an output: a file in the output folder, or in a MATLAB package
    folder ``+<name>/`` there (never a path out of it: ``--prune`` removes what records name)."""
    parts = file.split("/")
    return (0 < len(parts) <= 2 and all(part not in ("", ".", "..") and "\\" not in part for part in parts)
            and (len(parts) == 1 or parts[0].startswith("+")))


@contextmanager
def manifest_lock(out: Path) -> Iterator[None]:
    """Hold an exclusive lock on ``out``'s manifest (released when the block ends).

    The lock is taken on the output folder itself, so no lock file is left in it for ``git
    add -A`` to commit; a lock file of an earlier version, empty, is removed under the lock. A
    file system that cannot lock a folder gets the lock file (kept: removing a lock file
    another build may be waiting on would let a third build take a second lock).
    """
    try:
        out.mkdir(parents=True, exist_ok=True)
        descriptor = os.open(out, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    except OSError as exc:
        raise OutputError(f"cannot write {exc.filename or out}: {exc.strerror or exc}") from None
    try:
        if fcntl is None:   # pragma: no cover - not POSIX: builds are not serialized
            yield
            return
        try:
            fcntl.flock(descriptor, fcntl.LOCK_EX)
        except OSError:   # pragma: no cover - a file system without folder locks (some NFS)
            with _lock_file(out):
                yield
            return
        old = out / LOCK
        with suppress(OSError):
            if (info := os.lstat(old)).st_size == 0 and stat.S_ISREG(info.st_mode):
                os.unlink(old)
        yield
    finally:
        os.close(descriptor)   # releases the lock


@contextmanager
def _lock_file(out: Path) -> Iterator[None]:   # pragma: no cover - see manifest_lock
    lock = out / LOCK
    try:
        descriptor = os.open(lock, os.O_WRONLY | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0), 0o644)
    except OSError as exc:
        raise OutputError(f"cannot write {lock}: {exc.strerror or exc}") from None
    try:
        fcntl.flock(descriptor, fcntl.LOCK_EX)
        yield
    finally:
        os.close(descriptor)


def update_manifest(out: Path, built: dict[str, dict], current: dict[str, dict], claimed: set[str],
                    prune: bool) -> dict[str, list[tuple[str, str]]]:
    """Merge this run's records into the manifest on disk, under the lock, and replace it
    atomically (a manifest that is a link: the link itself); returns the orphaned outputs
    (``orphaned``: ``claimed`` are the files this run made), each with the reason ``--prune``
    keeps it ("" if it removes it), removed with their records when ``prune``.

    ``built`` records replace what is on disk; ``current`` (up-to-date) records are only put
    back if missing, so a newer record written meanwhile by a concurrent build is kept.
    """
    from .output import write_all

    with manifest_lock(out):
        manifest = current | load_manifest(out) | built
        orphans = sorted_orphans(out, manifest, orphaned(out, manifest, claimed))
        for name, files in orphans.items():
            if prune or not files:   # pruned, kept files are the user's from now on
                del manifest[name]
        removed = [out / file for files in orphans.values() for file, kept in files if not kept] if prune else []
        document = {"version": 1, "robots": dict(sorted(manifest.items()))}
        write_all({out / MANIFEST: (json.dumps(document, indent=2) + "\n").encode()}, remove=removed,
                  replace_links=True)
        for folder in sorted({path.parent for path in removed} - {out}, reverse=True):   # +<name>/, if empty now
            with suppress(OSError):
                folder.rmdir()
    return {name: files for name, files in orphans.items() if files}


def sorted_orphans(out: Path, manifest: dict[str, dict], orphans: dict[str, list[str]],
                   ) -> dict[str, list[tuple[str, str]]]:
    """Each orphaned output with the reason ``--prune`` keeps it, "" when it may remove it."""
    from .prune import sort_orphans

    return {name: sort_orphans(out, manifest[name]["outputs"], files, OUTPUT_NAMES) for name, files in orphans.items()}


def orphaned(out: Path, manifest: dict[str, dict], claimed: set[str]) -> dict[str, list[str]]:
    """Per record of a robot file that no longer exists, its outputs still in ``out`` that no
    record of an existing robot file lists and that are not among ``claimed`` (a renamed
    robot file's outputs belong to its new name)."""
    root = out.resolve()
    gone = {name for name in manifest if not (root / name).exists()}
    live = {file for name, record in manifest.items() if name not in gone for file in record["outputs"]}
    taken = live | claimed
    taken |= {file.split("/")[0] for file in taken if "/" in file}   # a MATLAB package +<name>/ as a whole
    return {name: sorted(file for file in manifest[name]["outputs"]
                         if file not in taken and file.split("/")[0] not in taken and os.path.lexists(out / file))
            for name in sorted(gone)}


def leftover_logs(out: Path, name: str, files: dict[str, bytes]) -> list[Path]:
    """The logs of failures that this run's outputs of robot ``name`` make stale: ``<name>.log``
    once its PDF is built, a target's (the extension's compiler log) once its first file is."""
    logs = [out / f"{name}.log"] if f"{name}.pdf" in files else []
    for target in _TARGETS:
        if target.stale and target.outputs[0].format(name) in files:
            logs += [out / pattern.format(name) for pattern in target.stale]
    return logs


def build(paths: list[Path], out: Path, kinds: tuple[str, ...], jobs: int, check: bool,
          template_dir: Path | None, note: Callable[[str], None] | None = None, prune: bool = False) -> list[Outcome]:
    """Build (or with ``check`` compare) every robot file under ``paths``; ``note`` receives
    remarks for the user (a malformed manifest). Outputs of robot files that no longer exist
    are reported after the others (``orphaned``), and with ``prune`` removed (``pruned``)."""
    from .output import check_output_folder, write_all
    from .prune import check_prune_folder
    from .solve import planned_files

    if prune and not check:
        check_prune_folder(out)
    sources = discover(paths)
    names = check_names(sources)
    # an --out that cannot hold the outputs is refused before any work (--check writes nothing)
    check_output_folder(out, [file for robot, _, _ in names.values() for file in planned_files(robot, kinds)],
                        writable=not check)
    # --check compares bytes, never the manifest (it reads it for orphaned outputs only)
    manifest = load_manifest(out, note)
    if not check:
        check_previous_owners(names, out, manifest)
    outcomes: dict[str, Outcome] = {}
    pending: list[tuple[Path, str]] = []
    current: dict[str, dict] = {}
    for source in sources:
        name = str(source)
        key = "" if check else input_key(source, kinds, template_dir)
        record = manifest.get(manifest_key(source, out))
        if record is not None and key and record["key"] == key and _outputs_match(out, record["outputs"]):
            outcomes[name] = Outcome(name, "up to date", outputs=record["outputs"], sheet=record.get("sheet", {}))
            current[manifest_key(source, out)] = record
        else:
            pending.append((source, key))
    templates, folder = str(template_dir) if template_dir else None, None if check else str(out)
    if len(pending) <= 1 or jobs <= 1:
        results = [(s, k, _work(str(s), kinds, templates, folder)) for s, k in pending]
    else:
        results = _parallel(pending, kinds, templates, folder, jobs)
    built: dict[str, dict] = {}
    # this run's outputs, and every output name of a robot it reads (one that fails keeps its files)
    claimed = {file for record in current.values() for file in record["outputs"]}
    claimed |= {pattern.format(robot) for robot, _, _ in names.values() for pattern in OUTPUT_NAMES}
    for source, key, (files, error, seconds, sheet, robot) in results:
        name = str(source)
        if files is None:
            outcomes[name] = Outcome(name, "failed", seconds, error)
            continue
        claimed |= files.keys()
        logs = leftover_logs(out, robot, files)
        if error:   # no PDF: the other outputs, the .tex and the log are written, not recorded
            if not check:   # an older PDF would disagree with the new .tex: it goes, as the message says
                from ..render.sheets.pdf import stale_beside

                stale, said = stale_beside(out, robot, made=False)
                write_all({out / file: data for file, data in files.items()}, remove=logs + stale)
                error += said
            outcomes[name] = Outcome(name, "failed", seconds, error)
            continue
        hashes = {file: _sha(data) for file, data in files.items()}
        if check:
            problems = [f"{out / file}: missing" if not (out / file).is_file() else f"{out / file}: differs"
                        for file, data in files.items() if not file.endswith(EXTENSION_SUFFIX)   # compiled: built, not compared
                        and (not (out / file).is_file() or (out / file).read_bytes() != data)]
            problems += [f"{log}: the log of a failed build (a build removes it)" for log in logs if os.path.lexists(log)]
            outcomes[name] = Outcome(name, "differs" if problems else "current", seconds, outputs=hashes,
                                     problems=problems, sheet=sheet)
        else:
            write_all({out / file: data for file, data in files.items()}, remove=logs)
            outcomes[name] = Outcome(name, "built", seconds, outputs=hashes, sheet=sheet)
            # the manifest keeps what the bytes determine (pages, overfull lines), not the time
            kept = {k: v for k, v in sheet.items() if k != "seconds"}
            built[manifest_key(source, out)] = {"key": key, "outputs": hashes, **({"sheet": kept} if kept else {})}
    if check:
        orphans = sorted_orphans(out, manifest, {k: files for k, files in orphaned(out, manifest, claimed).items()
                                                 if files})
    else:
        orphans = update_manifest(out, built, current, claimed, prune)
    status = "pruned" if prune and not check else "orphaned"
    extra = [Outcome(os.path.relpath(os.path.normpath(out.resolve() / key)), status,   # relative to the cwd
                     problems=[orphan_line(out / file, kept, status) for file, kept in files])
             for key, files in orphans.items()]
    return [outcomes[str(s)] for s in sources] + extra


def orphan_line(path: Path, kept: str, status: str) -> str:
    """What happened to an orphaned output (``kept``: why ``--prune`` keeps it, or "")."""
    if status == "pruned":
        return f"{path}: kept ({kept})" if kept else f"{path}: removed"
    return f"{path}: orphaned (--prune keeps it: {kept})" if kept else f"{path}: orphaned"


def _outputs_match(out: Path, outputs: dict[str, str]) -> bool:
    try:
        return bool(outputs) and all((out / file).is_file() and _sha((out / file).read_bytes()) == digest
                                     for file, digest in outputs.items())
    except OSError:
        return False
