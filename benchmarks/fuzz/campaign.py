"""Fuzz campaign: mutate the library models and put every mutant through every `lagc` command.

    python benchmarks/fuzz/campaign.py [--count N] [--seed S] [--timeout SECONDS] [--out DIR] [--keep K]

Each mutant (`mutations.py`) is written to a file and run through `lagc check`, `lagc eom`,
`lagc run --stop 0.1` on both backends and `--emit c` / `--emit numpy` (`outcomes.py`). A mutant
that `lagc check` rejects is not run through the other commands: they load the model the same
way and would fail the same way. Every command runs in its own child process with a limit on
memory and on CPU time (`outcomes.run_isolated`), all on one core. The chain of `pendulum_chain.lag` is cut from 12 links to 3: the
campaign is about robustness, and `lagc eom` of 12 links alone takes 20 s.

Outcomes are counted per command: successes, located errors (`file:line:col: error:` or
`lagc: error:`), simulation failures (time, state, remedy), errors without a location, and the
offending ones: tracebacks (`Traceback` or `internal error` on stderr, or an exit code other
than 0 and 1), signals, and hangs (over the hard limit of CPU time). Answers that took more than the
soft limit are counted as "slow" and listed by mutant, but they are not offences (see outcomes.py). The first mutant of each distinct offence is
saved for reproduction: DIR/NNN-category/ holds the model, the command and its stderr.
DIR/report.md has the counts and the list of offences.
"""
from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))   # benchtools, from benchmarks/
import benchtools  # noqa: E402  (first: one BLAS thread before NumPy is imported)

import argparse  # noqa: E402
import collections  # noqa: E402
import os  # noqa: E402
import random  # noqa: E402
import shlex  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402

import lagdsl.run.runner  # noqa: E402,F401  (imported once here, inherited by every child)
import scipy.integrate  # noqa: E402,F401
from mutations import library, mutants  # noqa: E402
from outcomes import CATEGORIES, COMMANDS, OFFENDING, arguments, classify, run_isolated, signature  # noqa: E402

def main() -> int:
    options = _options()
    benchtools.pin_to_one_core()
    options.out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="lagdsl-fuzz-") as work:
        os.environ["LAGDSL_CACHE"] = str(Path(work) / "cache")
        started = time.monotonic()
        tally, offences, slow, done = _campaign(options, Path(work), started)
    report = _report(options, tally, offences, slow, done, time.monotonic() - started)
    print(report)
    return 0


def _options():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--count", type=int, default=10**4, help="number of mutants (default 10^4)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    parser.add_argument("--timeout", type=float, default=20.0,
                        help="soft CPU time limit per command in seconds: slower answers are listed (default 20)")
    parser.add_argument("--hard-limit", type=float, default=120.0,
                        help="hard CPU time limit per command in seconds: a hang (default 120)")
    parser.add_argument("--out", type=Path, default=Path("fuzz-out"), help="report and reproducers (default fuzz-out/)")
    parser.add_argument("--keep", type=int, default=20, help="reproducers to save at most (default 20)")
    return parser.parse_args()


def _campaign(options, work: Path, started: float):
    """Run the mutants; returns the counts per command and category, the offences
    (signature -> [count, reproducer directory or None, mutant numbers]), the slow answers and the
    number of mutants run.
    The report is rewritten every 50 mutants, so a campaign cut short still has one."""
    tally = collections.Counter()
    offences: dict[str, list] = {}
    slow: list[str] = []
    seeds = {name: text.replace("n = 12", "n = 3") for name, text in library(benchtools.MODELS).items()}
    stream = mutants(seeds, random.Random(options.seed))
    for number in range(options.count):
        mutant = next(stream)
        model = work / mutant.model
        model.write_text(mutant.text, encoding="utf-8")
        for command in COMMANDS:
            exit_code, stderr, cpu = run_isolated(arguments(command, str(model)), options.hard_limit, work)
            category = classify(exit_code, stderr, cpu, options.timeout)
            tally[command, category] += 1
            if category == "slow":
                slow.append(f"{number} ({command}, {cpu:.0f} s)")
            elif category in OFFENDING:
                _record(offences, signature(category, command, exit_code, stderr), options, number, mutant,
                        command, category, stderr)
            if command == "check" and exit_code != 0:
                break
        if (number + 1) % 50 == 0:
            found = sum(count for count, _, _ in offences.values())
            print(f"{number + 1} mutants, {found} offending outcomes", file=sys.stderr, flush=True)
            _report(options, tally, offences, slow, number + 1, time.monotonic() - started)
    return tally, offences, slow, options.count


def _record(offences, name, options, number, mutant, command, category, stderr) -> None:
    if name in offences:
        offences[name][0] += 1
        offences[name][2].append(number)
        return
    saved = len([1 for _, where, _ in offences.values() if where]) < options.keep
    where = options.out / f"{number:05d}-{category}" if saved else None
    offences[name] = [1, where, [number]]
    if where:
        where.mkdir(parents=True, exist_ok=True)
        (where / mutant.model).write_text(mutant.text, encoding="utf-8")
        line = shlex.join(["lagc", *arguments(command, mutant.model)])
        (where / "command.sh").write_text(f"# {', '.join(mutant.mutations)}\n{line}\n", encoding="utf-8")
        (where / "stderr.txt").write_text(stderr, encoding="utf-8")


def _report(options, tally, offences, slow, done: int, elapsed: float) -> str:
    """Write DIR/report.md (atomically) and return its text."""
    rows = [[command, *(tally[command, category] for category in CATEGORIES)] for command in COMMANDS]
    progress = "" if done == options.count else f" (so far: {done} of {options.count})"
    lines = [f"# Fuzz campaign: {done} mutants{progress}, seed {options.seed}, "
             f"CPU time limits {options.timeout:g} s (slow) and {options.hard_limit:g} s (hang)",
             "", f"{elapsed:.0f} s on one core. {benchtools.machine_description()}", "",
             benchtools.markdown_table(["command", *CATEGORIES], rows), ""]
    if not offences:
        lines.append("No tracebacks, signals or hangs.")
    else:
        lines += ["## Offences (first reproducer saved)", ""]
        lines += [f"- {count} x {name}: {where or 'not saved (--keep)'}; mutants {', '.join(map(str, numbers))}"
                  for name, (count, where, numbers) in sorted(offences.items(), key=lambda item: -item[1][0])]
    if slow:
        lines += ["", f"Slow answers (mutant, command, CPU time): {', '.join(slow)}"]
    text = "\n".join(lines) + "\n"
    partial = options.out / "report.md.partial"
    partial.write_text(text, encoding="utf-8")
    partial.replace(options.out / "report.md")
    return text


if __name__ == "__main__":
    sys.exit(main())
