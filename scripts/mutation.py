"""Mutation testing of the modules issue 25 names, with mutmut (not in CI: a full run takes about
40 minutes on two cores).

    PYTHONPATH=src .venv/bin/python scripts/mutation.py            # run mutmut, then the table
    PYTHONPATH=src .venv/bin/python scripts/mutation.py --report   # the table of the last run
    PYTHONPATH=src .venv/bin/python scripts/mutation.py --survivors [MODULE]  # what lived

The modules and the tests each mutant runs are set in pyproject.toml ([tool.mutmut]); mutmut
runs, for each mutant, only the selected tests that called the mutated function. Mutants that
cannot change behaviour are listed with the reason in scripts/mutation_equivalent.txt and left
out of the rate. The rate is killed (a test failed, or the run timed out: an endless loop is
caught) over all other mutants; "no tests" and survived mutants count against it.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MODULES = ("mesh/validate.py", "tactile/braille.py", "relief/legibility.py", "clean/scale.py")
EQUIVALENT_FILE = ROOT / "scripts" / "mutation_equivalent.txt"
GOAL = 0.85
# mutmut's exit codes (mutmut/stats.py): 1 and 3 killed, 0 survived, 33 and 5 no tests, timeouts.
KILLED = {1: "killed", 3: "killed"}
TIMEOUT = {36, 24, -24, 152, 255}


@dataclass(frozen=True)
class ModuleScore:
    module: str
    total: int
    equivalent: int
    killed: int
    timeout: int
    survived: int
    no_tests: int
    not_checked: int

    @property
    def rate(self) -> float:
        counted = self.total - self.equivalent
        return (self.killed + self.timeout) / counted if counted else 0.0


def equivalent_mutants() -> dict[str, str]:
    """Mutant name -> why it cannot change behaviour (one per line: `name  # reason`)."""
    found = {}
    if EQUIVALENT_FILE.is_file():
        for line in EQUIVALENT_FILE.read_text(encoding="utf-8").splitlines():
            name, _, why = line.partition("#")
            if name.strip():
                if not why.strip():
                    raise SystemExit(f"{EQUIVALENT_FILE.name}: {name.strip()} has no reason")
                found[name.strip()] = why.strip()
    return found


def scores() -> list[ModuleScore]:
    equivalent = equivalent_mutants()
    out = []
    for module in MODULES:
        meta = ROOT / "mutants" / "src" / "tamp_os" / f"{module}.meta"
        if not meta.is_file():
            raise SystemExit(f"no mutmut results for {module}: run this script without --report first")
        codes = json.loads(meta.read_text())["exit_code_by_key"]
        tally = Counter()
        for name, code in codes.items():
            if name in equivalent:
                tally["equivalent"] += 1
            elif code in KILLED:
                tally["killed"] += 1
            elif code in TIMEOUT:
                tally["timeout"] += 1
            elif code == 0:
                tally["survived"] += 1
            elif code in (5, 33):
                tally["no_tests"] += 1
            elif code is None:
                tally["not_checked"] += 1
            else:
                tally["survived"] += 1  # suspicious or a crash of the runner: not counted as a kill
        out.append(ModuleScore(module, len(codes), tally["equivalent"], tally["killed"], tally["timeout"],
                               tally["survived"], tally["no_tests"], tally["not_checked"]))
    return out


def table(rows: list[ModuleScore]) -> str:
    lines = ["| module | mutants | equivalent | killed | timeout | survived | no tests | not checked | kill rate |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        lines.append(f"| {r.module} | {r.total} | {r.equivalent} | {r.killed} | {r.timeout} | {r.survived} | {r.no_tests} "
                     f"| {r.not_checked} | {r.rate:.1%} |")
    return "\n".join(lines)


def survivors(module: str | None) -> list[str]:
    equivalent = equivalent_mutants()
    names = []
    for m in MODULES:
        if module and module not in m:
            continue
        codes = json.loads((ROOT / "mutants" / "src" / "tamp_os" / f"{m}.meta").read_text())["exit_code_by_key"]
        names += [n for n, c in codes.items() if n not in equivalent and c not in KILLED and c not in TIMEOUT]
    return names


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--report", action="store_true", help="only print the table of the last run")
    ap.add_argument("--survivors", nargs="?", const="", metavar="MODULE", help="list the mutants that were not killed")
    ap.add_argument("--max-children", type=int, default=2)
    args = ap.parse_args()
    if args.survivors is not None:
        print("\n".join(survivors(args.survivors or None)))
        return 0
    if not args.report:
        env = {**os.environ, "TAMP_FIXTURES": str(ROOT.parent / "shared" / "fixtures"), "TAMP_STRICT": "1",
               "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
        mutmut = Path(sys.executable).with_name("mutmut")
        subprocess.run([str(mutmut), "run", "--max-children", str(args.max_children)], cwd=ROOT, env=env, check=False)
    rows = scores()
    print(table(rows))
    return 0 if all(r.rate >= GOAL for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
