"""Run the command line in a child Python and measure it: its exit code, its one error line, its own peak memory (shared by the tests and benchmarks/bench_guards.py)."""

import hashlib
import json
import logging
import os
import resource
import signal
import struct
import subprocess
import sys
import textwrap
import time
import zlib
from pathlib import Path
import numpy as np
import pytest
import tifffile
from PIL import Image
from conftest import ROOT, run_cli as run


PYTHON = sys.executable


SRC = str(ROOT / "src")


def run_limited(code: str, *args, limit_gb: float, timeout_s: float = 120) -> tuple[int, str, str, float]:
    """Run `code` in a child Python under RLIMIT_AS = limit_gb: (exit code, stdout, stderr, peak MB).

    The peak is the child's own (see PEAK); the address-space limit is set between fork and exec.
    """
    limit = int(limit_gb * 2**30)

    def limit_memory():
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))

    # A plain environment: the product's own peak, not what another test left in os.environ.
    keep = ("PATH", "HOME", "LANG", "LC_ALL", "TMPDIR", "TAMP_STRICT")
    env = {**{k: os.environ[k] for k in keep if k in os.environ},
           "PYTHONPATH": SRC, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    proc = subprocess.Popen([PYTHON, "-c", code, *map(str, args)], preexec_fn=limit_memory, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        out, err = proc.communicate(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        proc.kill()
        raise
    # The child reports its own peak on its last PEAK_MB line (see PEAK below).
    peak = 0.0
    for line in err.splitlines()[::-1]:
        if line.startswith("PEAK_MB "):
            peak = float(line.split()[1])
            break
    return proc.returncode, out, err, peak


# The child's peak is VmHWM, the high-water resident size of its own address space since exec.
# Not ru_maxrss: Linux carries the address space that exec replaces into ru_maxrss (RUSAGE_SELF,
# RUSAGE_CHILDREN and wait4 alike). A child forked from pytest (preexec_fn forces fork) starts
# with pytest's whole resident set copied, so late in the suite it read 430 MB before doing
# anything; a vfork'ed child inherits pytest's lifetime peak the same way.
PEAK = textwrap.dedent("""
    import sys as _s
    with open('/proc/self/status') as _f:
        _kb = next(int(_l.split()[1]) for _l in _f if _l.startswith('VmHWM:'))
    print('PEAK_MB', _kb / 1024, file=_s.stderr)
    """)


# A refusal before decoding costs the interpreter and the library's imports (about 80 MB): the
# bounds are far below what decoding each bomb would take (1.2 to 4.3 GB).
REFUSAL_PEAK_MB = 300


def cli_code(*argv) -> str:
    """Child code: run the CLI with argv (and sys.argv[1:]), print its peak, exit with its code."""
    return textwrap.dedent(f"""
        import sys
        from tamp_os.cli.commands import main
        code = main({list(map(str, argv))!r} + sys.argv[1:])
        """) + PEAK + "sys.exit(code)\n"


def run_cli_child(*argv, timeout_s: float = 60, src: str = SRC) -> tuple[int, str, float, float, float]:
    """The CLI in a child Python (no memory limit): (exit code, stderr, peak MB (see PEAK), seconds
    spent in main(), wall seconds of the whole child, its start-up included). `src`: the package's
    source folder (another revision's, for a benchmark's before and after)."""
    code = textwrap.dedent(f"""
        import sys, time
        from tamp_os.cli.commands import main
        t0 = time.perf_counter()
        code = main({list(map(str, argv))!r})
        print('SECONDS', time.perf_counter() - t0, file=sys.stderr)
        """) + PEAK + "sys.exit(code)\n"
    keep = ("PATH", "HOME", "LANG", "LC_ALL", "TMPDIR", "TAMP_STRICT")
    env = {**{k: os.environ[k] for k in keep if k in os.environ}, "PYTHONPATH": str(src),
           "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    started = time.monotonic()
    proc = subprocess.run([PYTHON, "-c", code], env=env, capture_output=True, text=True, timeout=timeout_s, check=False)
    wall = time.monotonic() - started
    found = {line.split()[0]: float(line.split()[1]) for line in proc.stderr.splitlines() if line.startswith(("PEAK_MB ", "SECONDS "))}
    return proc.returncode, proc.stderr, found.get("PEAK_MB", 0.0), found.get("SECONDS", 0.0), wall


def run_tamp(*argv, cwd=None, timeout_s: float = 240, env: dict | None = None) -> subprocess.CompletedProcess:
    """`tamp-os ARGV` as a user types it, in a child Python (the package from this tree), run in
    `cwd`: its exit code, stdout and stderr (not a terminal, as a screen reader's pipe)."""
    keep = ("PATH", "HOME", "LANG", "LC_ALL", "TMPDIR", "TAMP_STRICT")
    base = {**{k: os.environ[k] for k in keep if k in os.environ}, "PYTHONPATH": SRC,
            "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    return subprocess.run([PYTHON, "-m", "tamp_os.cli", *map(str, argv)], cwd=cwd, env={**base, **(env or {})},
                          capture_output=True, text=True, timeout=timeout_s, check=False)


def one_error_line(err: str) -> str:
    lines = [line for line in err.splitlines() if line.startswith("error:")]
    assert len(lines) == 1, err
    assert "Traceback" not in err, err
    return lines[0]


MB = 1_000_000


ADVERSARIAL_XML = {
    "unclosed_channel": "<OME>" + "<Channel" + " a" * (MB // 2),
    "long_comment": "<OME><!--" + " Channel Name" * (MB // 13) + "--><Channel Name=\"DAPI\"/></OME>",
    "many_attributes": "<OME><Channel " + " ".join(f"a{i}=\"x\"" for i in range(MB // 10)) + " Name=\"GFP\"/></OME>",
    "entity_bomb": "<?xml version=\"1.0\"?><!DOCTYPE l [<!ENTITY a \"" + "a" * 1000 + "\">" + "".join(
        f"<!ENTITY a{i} \"&a{i - 1 if i else ''};&a{i - 1 if i else ''};\">" for i in range(1, 30)) + "]><OME>&a29;</OME>",
}


SIDECAR_CASES = {
    "blank_lines": "\n" * MB,
    "spaces_one_line": " " * MB,
    "dollars": "$" * MB,
    "key_prefix_repeated": "PixelSize" * (MB // 9),
    "jeol_marker_spaces": "$$SM_MICRON_MARKER" + " " * MB + "x",
    "many_keys": "$$SM_MICRON_BAR \n" * (MB // 17),
}


# The peak of one read alone: the child imports the readers, resets its high-water mark
# (/proc/self/clear_refs 5), reads, and reports VmHWM above its resident size before the read.
READ_PEAK = textwrap.dedent("""
    import sys, time
    import numpy as np
    from tamp_os.read.image import read_image
    {imports}
    def _kb(key):
        with open('/proc/self/status') as f:
            return next(int(l.split()[1]) for l in f if l.startswith(key))
    before = _kb('VmRSS:')
    with open('/proc/self/clear_refs', 'w') as f:
        f.write('5')
    t0 = time.perf_counter()
    try:
        {call}
        print('OK', file=sys.stderr)
    except Exception as exc:
        print('ERROR', type(exc).__name__, str(exc).replace(chr(10), ' '), file=sys.stderr)
    print('SECONDS', time.perf_counter() - t0, file=sys.stderr)
    print('READ_PEAK_MB', (_kb('VmHWM:') - before) / 1024, file=sys.stderr)
    """)


def read_peak(path, *, call: str = "read_image(sys.argv[1], max_decoded_gb=100, max_memory_gb=100)", imports: str = "",
              limit_gb: float = 8.0, timeout_s: float = 300) -> tuple[str, float, float]:
    """Run `call` on `path` in a child Python: (its outcome line, 'OK' or 'ERROR <type> <message>';
    seconds; MB of memory the call took at its peak above the process before it)."""
    code = READ_PEAK.format(imports=imports or "pass", call=call)
    _, _, err, _ = run_limited(code, path, limit_gb=limit_gb, timeout_s=timeout_s)
    found = {line.split()[0]: line for line in err.splitlines() if line.startswith(("OK", "ERROR", "SECONDS ", "READ_PEAK_MB "))}
    if "READ_PEAK_MB" not in found:
        raise AssertionError(err[-3000:])
    outcome = found.get("OK") or found.get("ERROR", "")
    return outcome, float(found["SECONDS"].split()[1]), float(found["READ_PEAK_MB"].split()[1])
