"""Work-precision diagrams: every lagdsl integrator (C backend) against scipy's solve_ivp and CyRK
(on the NumPy backend's right-hand side) on four problems, with `lagdsl.bench`.

- the chaotic double pendulum up to t = 10 (models/double_pendulum.lag, scene chaos);
- Kepler with eccentricity 0.6 over 100 orbits, rows every 1/100 orbit; at whole periods the
  exact solution (r = r0, theta = 2 pi k) checks the reference;
- the stiff spring (tests/run/models/stiff_spring.lag, K = 1e8);
- the car axis (models/car_axis.lag, constrained, mildly stiff).

Writes benchmarks/work_precision/<problem>.png, .csv and .md (its part of the README), and after
each problem the section between the markers in benchmarks/README.md from every problem's .md
(the rest of that file is kept; `--only` reruns some problems and keeps the others' parts). Takes several minutes:

    nice python benchmarks/work_precision.py [--repeat N] [--time-limit S] [--only NAME,...]
"""
from __future__ import annotations

import argparse
import math
import os
import re
import sys
from pathlib import Path

import numpy as np

import lagdsl
from lagdsl import bench, plots
from lagdsl.scene import Overrides

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "benchmarks" / "work_precision"
README = ROOT / "benchmarks" / "README.md"
BEGIN, END = "<!-- work_precision.py: begin -->", "<!-- work_precision.py: end -->"
LEVELS = (1e-4, 1e-7, 1e-10)

ECCENTRICITY = 0.6
SEMI_MAJOR = 1 / (1 - ECCENTRICITY)                 # r0 = 1 at periapsis, GM = 1
PERIOD = 2 * math.pi * SEMI_MAJOR ** 1.5
KEPLER = f"""model KeplerE06 "Kepler problem, eccentricity 0.6, starting at periapsis"
  coordinate r(start = 1.0);
  coordinate theta(start = 0, velocity = {math.sqrt(1 + ECCENTRICITY)!r});
  T = (der(r)^2 + r^2*der(theta)^2)/2;
  U = -1/r;
  scene orbits
    time(stop = {100 * PERIOD!r}, interval = {PERIOD / 100!r});
    integrator dop853(rtol = 1e-10, atol = 1e-12);
    output r, theta;
  end orbits;
end KeplerE06;
"""


def problems():
    """(name, title, model, scene, overrides)."""
    kepler = OUT / "kepler_e06.lag"
    kepler.write_text(KEPLER)
    return [
        ("double_pendulum", "chaotic double pendulum, t <= 10", ROOT / "models" / "double_pendulum.lag", "chaos",
         Overrides(stop=10.0)),
        ("kepler", "Kepler e = 0.6, 100 orbits", kepler, "orbits", Overrides()),
        ("stiff_spring", "stiff spring (K = 1e8), 10 s", ROOT / "tests" / "run" / "models" / "stiff_spring.lag",
         "stiff", Overrides()),
        ("car_axis", "car axis, 3 s (constrained)", ROOT / "models" / "car_axis.lag", "bumps", Overrides()),
    ]


def kepler_reference_check(report) -> str:
    """The reference against the exact solution at whole periods (every 100th row)."""
    values = report.reference.values[::100]
    orbits = np.arange(len(values))
    exact = np.column_stack([np.ones(len(values)), 2 * math.pi * orbits])
    return f"the reference differs from the exact solution at whole periods by {np.max(np.abs(values - exact)):.2g}"


def fastest_at(rows, level: float) -> float | None:
    times = [r.seconds for r in rows if r.failure is None and r.error is not None and r.error <= level]
    return min(times) if times else None


def introduction(time_limit: float, load: str) -> list[str]:
    return ["## Work against precision (`work_precision.py`)", "",
            "Produced by `python benchmarks/work_precision.py` with `lagdsl.bench` (what `lagc bench --peers` "
            "runs). Each method runs its ladder (rtol 1e-3 .. 1e-13 with atol scaled by the scene's ratio; "
            "steps of 4 down to 1/64 output intervals for rk4 and gauss); the error is the largest absolute "
            "difference over the output rows and columns from a reference computed by the generated C in "
            "`__float128` (dop853 at rtol 1e-20, radau5 at 1e-22 for stiff scenes), whose own accuracy is "
            "given. lagdsl runs the C backend; scipy and CyRK integrate the NumPy backend's right-hand side "
            "(a Python function, as a user of those libraries would write it). Wall-clock seconds of the "
            "integration alone, best of the repeats, on one machine shared with other work: read the ratios. "
            f"A ladder stops after a setting that takes more than {time_limit:g} s. The times are wall-clock: "
            f"on a loaded machine (load average {load} when this section was written) they are inflated and "
            "noisy, most for the longer runs; run the script on an idle machine with `--repeat 3` for clean "
            "curves.", ""]


def problem_section(name: str, title: str, report, extra: str) -> str:
    """One problem's part of the README section (also kept as work_precision/NAME.md)."""
    lines = [f"### {title}", "", f"![{name}](work_precision/{name}.png)", "", report.reference.describe() + ".",
             *([extra + "."] if extra else []), "",
             "Fastest setting reaching each error level (seconds; - = not reached):", "",
             "| method | " + " | ".join(f"error <= {level:g}" for level in LEVELS) + " |",
             "| --- |" + " ---: |" * len(LEVELS)]
    methods: dict[str, list] = {}
    for row in report.rows:
        methods.setdefault(row.setting.method, []).append(row)
    for method, rows in methods.items():
        cells = [fastest_at(rows, level) for level in LEVELS]
        lines.append(f"| {method} | " + " | ".join("-" if c is None else f"{c:.3g}" for c in cells) + " |")
    lines += [f"- {note}" for note in report.notes]
    return "\n".join(lines) + "\n"


def write_readme(time_limit: float, names: list[str]) -> None:
    """The section between the markers: the introduction and every problem's part written so far
    (by this run or an earlier one); the rest of the README is kept."""
    parts = [(OUT / f"{name}.md").read_text() for name in names if (OUT / f"{name}.md").exists()]
    load = ", ".join(f"{value:.1f}" for value in os.getloadavg())
    text = "\n".join([BEGIN, *introduction(time_limit, load), "\n".join(parts).rstrip("\n"), "", END]) + "\n"
    readme = README.read_text()
    if BEGIN in readme:
        readme = re.sub(re.escape(BEGIN) + ".*?" + re.escape(END) + "\n?", lambda _: text, readme, flags=re.S)
    else:
        readme = readme.rstrip("\n") + "\n\n" + text
    README.write_text(readme)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=1, help="runs per setting (short ones are repeated anyway)")
    parser.add_argument("--time-limit", type=float, default=3.0,
                        help="seconds: a setting slower than this ends its ladder (default 3)")
    parser.add_argument("--only", help="comma-separated problems to run (the README gets only those)")
    arguments = parser.parse_args()
    OUT.mkdir(parents=True, exist_ok=True)
    names = [problem[0] for problem in problems()]
    for name, title, path, scene, overrides in problems():
        if arguments.only and name not in arguments.only.split(","):
            continue
        print(f"{title} ...", file=sys.stderr)
        model = lagdsl.load(path)
        progress = bench.progress_bar()
        report = bench.run_bench(model, scene, overrides, peers=True, repeat=arguments.repeat, drift=True,
                                 progress=progress, time_limit=arguments.time_limit)
        progress.close()
        (OUT / f"{name}.png").write_bytes(plots.work_precision_png(report))
        (OUT / f"{name}.csv").write_text(report.csv())
        print(report.render(), flush=True)
        extra = kepler_reference_check(report) if name == "kepler" else ""
        (OUT / f"{name}.md").write_text(problem_section(name, title, report, extra))
        write_readme(arguments.time_limit, names)      # after each problem: a run cut short keeps its results
    return 0


if __name__ == "__main__":
    sys.exit(main())
