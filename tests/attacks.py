"""The harness of the attack suites (tests/test_attack_*.py): hostile inputs run through
``pbs`` as a user would, each held to one contract.

Cases run in a child process (``python -m tests.attacks CASES OUT``) under an address-space
limit, so that a bomb that gets through fails its case (a MemoryError) instead of taking
the machine down; inside it every case is ``app.cli.main(argv)`` in-process (one start-up
for hundreds of cases), with:

- an audit hook recording every file Python opens (``open``, ``os.open``: Pillow, trimesh,
  the project), so a case can prove that nothing under its "secret" folder was touched;
- file descriptors 1 and 2 redirected to files, so everything on stderr counts, C
  libraries' lines and Python warnings included;
- the peak resident set reset before the case (``/proc/self/clear_refs``) and read after;
- an alarm that ends a case that hangs (a FIFO opened, a huge loop).

The contract (``escapes``): the command either refused the input (exit 2, exactly one
stderr line ``pbs: error: ...``, none of the case's outputs written) or rendered it (exit
0, a PNG that decodes, an HDR image whose every value is finite and >= 0), in both cases
with nothing on stdout where the case passes ``-q``,
without a traceback, within ``MAX_SECONDS`` and ``MAX_PEAK`` of memory, without opening a
file under the case's secret folder, and without a refusal that quotes the secret's
contents or size.
"""

from __future__ import annotations

import json
import os
import resource
import signal
import subprocess
import sys
import tempfile
import time
import traceback
from dataclasses import asdict, dataclass, field
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
MAX_SECONDS = 30.0  # a case that takes longer is a hang (the alarm ends it at HANG_SECONDS)
HANG_SECONDS = 45
# Bytes of resident memory a case may add to the process's: the 1 GiB budget the suites
# pass as --max-memory, and room for a GL context and the interpreter's own.
MAX_PEAK = 1536 << 20
ADDRESS_SPACE = 8 << 30  # the child's limit: a bomb that gets through fails, not the machine
SECRET = "pbs-attack-secret-7f3a"  # what every secret file holds (and nothing else does)


def scene_head(width: int = 32, height: int = 18) -> str:
    """The start of every suite's scene files: a tiny image, a camera at +Z looking at
    the origin, one directional light along the view."""
    return (
        f"[render]\nwidth = {width}\nheight = {height}\n\n"
        "[camera]\nposition = [0.0, 0.0, 3.0]\ntarget = [0.0, 0.0, 0.0]\n\n"
        '[[lights]]\ntype = "directional"\ndirection = [0.0, 0.0, -1.0]\n\n'
    )


@dataclass
class Case:
    """One hostile input: ``argv`` for ``pbs``, run in ``cwd``; ``outputs`` must not exist
    after a refusal; nothing under ``secret`` may be opened; ``expect`` "refused" or
    "rendered" where the case knows (None: either passes the contract)."""

    id: str
    argv: list[str]
    cwd: str
    outputs: list[str] = field(default_factory=list)
    secret: str | None = None
    expect: str | None = None
    hdr: str | None = None  # an HDR output to check for non-finite values


@dataclass
class Outcome:
    id: str
    code: int | None
    stderr: str
    stdout: str
    exception: str | None
    seconds: float
    peak: int
    opened_secret: list[str]
    outputs_written: list[str]
    image_problem: str | None


def run_cases(
    cases: list[Case], folder: Path, timeout: float = 1200.0, tree: Path = REPO
) -> dict[str, Outcome]:
    """Every case in one child process running the project in ``tree`` (this checkout by
    default); a case the child died on gets code None and its exception says how it died,
    and the cases after it run in a new child."""
    results: dict[str, Outcome] = {}
    todo = list(cases)
    attempt = 0
    while todo:
        spec = folder / f"cases-{attempt}.json"
        out = folder / f"outcomes-{attempt}.jsonl"
        spec.write_text(json.dumps([asdict(c) for c in todo]), encoding="utf-8")
        env = {**os.environ, "PYTHONPATH": f"{tree}{os.pathsep}{REPO}",
               "PYTHONDONTWRITEBYTECODE": "1"}  # fmt: skip
        proc = subprocess.run(
            [sys.executable, "-m", "tests.attacks", str(spec), str(out)],
            cwd=tree, env=env, capture_output=True, text=True, timeout=timeout,
        )  # fmt: skip
        if out.exists():
            for line in out.read_text(encoding="utf-8").splitlines():
                if line.strip():
                    o = Outcome(**json.loads(line))
                    results[o.id] = o
        left = [c for c in todo if c.id not in results]
        if left:  # the child died on left[0]: it fails, the rest run in a new child
            why = f"the child process died here (exit {proc.returncode}): {proc.stderr[-600:]}"
            results[left[0].id] = Outcome(left[0].id, None, "", "", why, 0.0, 0, [], [], None)
            left = left[1:]
        todo, attempt = left, attempt + 1
    return results


def escapes(cases: list[Case], outcomes: dict[str, Outcome]) -> list[str]:
    """One line per case that broke the contract (see the module docstring)."""
    out = []
    for case in cases:
        o = outcomes.get(case.id)
        if o is None:
            continue
        problem = _problem(case, o)
        if problem:
            out.append(f"{case.id}: {problem}")
    return out


def _problem(case: Case, o: Outcome) -> str | None:
    if o.exception:
        return f"exception: {o.exception.splitlines()[-1][:300]}"
    if o.opened_secret:
        return f"opened a file outside the allowed folder: {o.opened_secret[0]}"
    if o.seconds > MAX_SECONDS:
        return f"took {o.seconds:.1f} s"
    if o.peak > MAX_PEAK:
        return f"peak memory grew by {o.peak >> 20} MiB"
    lines = [line for line in o.stderr.splitlines() if line.strip()]
    if "-q" in case.argv and o.stdout.strip() and o.code in (0, 2):
        return f"printed on stdout under -q: {o.stdout.strip()[:200]!r}"
    if o.code == 2:
        if len(lines) != 1 or not lines[0].startswith("pbs: error: "):
            return f"refused with {len(lines)} stderr lines: {o.stderr[:300]!r}"
        if SECRET in lines[0]:
            return f"the refusal quotes the secret: {lines[0][:200]}"
        if o.outputs_written:
            return f"refused but wrote {o.outputs_written}"
        if case.expect == "rendered":
            return f"expected a render, refused: {lines[0][:200]}"
        return None
    if o.code == 0:
        if o.image_problem:
            return o.image_problem
        if case.expect == "refused":
            return "expected a refusal, rendered"
        return None
    return f"exit code {o.code}: {o.stderr[-300:]!r}"


# --- the child ----------------------------------------------------------------------------


class _HangError(Exception):
    pass


def _peak_reset() -> None:
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
    except OSError:
        pass


def _rss(field_name: str) -> int:
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(field_name):
                return int(line.split()[1]) << 10
    return 0


def _real(cwd: str, path: str) -> str:
    return os.path.realpath(os.path.join(cwd, path))


def _inside(path: str, folder: str) -> bool:
    folder = os.path.realpath(folder)
    return path == folder or path.startswith(folder + os.sep)


def _image_problem(case: Case) -> str | None:
    import numpy as np
    from PIL import Image

    png = next((p for p in case.outputs if p.endswith(".png")), None)
    if png is not None:
        try:
            with Image.open(png) as image:
                image.load()
        except Exception as exc:
            return f"exit 0 but the PNG does not decode ({type(exc).__name__})"
    if case.hdr is not None:
        hdr = np.load(case.hdr) if case.hdr.endswith(".npy") else None
        if hdr is not None and not (np.all(np.isfinite(hdr)) and np.all(hdr >= 0.0)):
            return "exit 0 but the HDR image holds NaN, Inf or negative values"
    return None


# Options the project's code before the untrusted-input work did not have: a run against
# such a tree (PBS_ATTACK_LEGACY=1, how docs/stability.md's "before" counts were taken)
# leaves them out, so its cases meet the code's defaults instead of an argument error.
_NEW_OPTIONS = ("--max-memory", "--allow-path")


def _legacy(argv: list[str]) -> list[str]:
    out, skip = [], False
    for arg in argv:
        if skip:
            skip = False
        elif arg in _NEW_OPTIONS:
            skip = True
        else:
            out.append(arg)
    return out


def _child(spec: Path, out: Path) -> None:
    limit = ADDRESS_SPACE
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    cases = [Case(**c) for c in json.loads(spec.read_text(encoding="utf-8"))]
    if os.environ.get("PBS_ATTACK_LEGACY"):
        for case in cases:
            case.argv = _legacy(case.argv)
    opened: list[tuple[str, str]] = []  # (working folder, path as opened)

    def hook(event: str, args: tuple) -> None:
        if event == "open" and isinstance(args[0], str | bytes):
            opened.append((os.getcwd(), os.fsdecode(args[0])))

    sys.addaudithook(hook)

    def alarm(signum: int, frame: object) -> None:
        raise _HangError(f"no answer after {HANG_SECONDS} s")

    signal.signal(signal.SIGALRM, alarm)
    from app import cli

    saved = os.dup(1), os.dup(2)
    with out.open("a", encoding="utf-8") as results:
        for case in cases:
            os.chdir(case.cwd)
            with tempfile.TemporaryFile("w+") as err, tempfile.TemporaryFile("w+") as std:
                sys.stdout.flush(), sys.stderr.flush()
                os.dup2(std.fileno(), 1), os.dup2(err.fileno(), 2)
                opened.clear()
                _peak_reset()
                base = _rss("VmRSS")
                start = time.perf_counter()
                code, exception = None, None
                signal.alarm(HANG_SECONDS)
                try:
                    code = cli.main(list(case.argv))
                except BaseException:
                    exception = traceback.format_exc()
                finally:
                    signal.alarm(0)
                seconds = time.perf_counter() - start
                peak = max(_rss("VmHWM") - base, 0)
                sys.stdout.flush(), sys.stderr.flush()
                os.dup2(saved[0], 1), os.dup2(saved[1], 2)
                err.seek(0)
                stderr = err.read()
                std.seek(0)
                stdout = std.read()
            secret = case.secret
            touched = sorted(
                {real for cwd, p in opened if secret and _inside(real := _real(cwd, p), secret)}
            )
            written = [p for p in case.outputs if os.path.exists(p)] if code != 0 else []
            problem = _image_problem(case) if code == 0 else None
            line = Outcome(case.id, code, stderr, stdout, exception, seconds, peak, touched,
                           written, problem)  # fmt: skip
            results.write(json.dumps(asdict(line)) + "\n")
            results.flush()


if __name__ == "__main__":
    _child(Path(sys.argv[1]), Path(sys.argv[2]))
