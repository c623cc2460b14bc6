"""Run the app commands of the user guides (docs/), keep what they measured in ``experiments/apps/``, and regenerate
the blocks that quote it.

Every number the README states for ``hybridhyst-fit``, ``-identify``, ``-train``, ``-simulate`` and the own-data
example comes from a JSON file this script writes (``experiments/apps/<run>.json``: the command, its wall time,
the machine's load, the terminal summary and the run's ``summary.json`` / ``metrics.json`` / ``discovery.json``
without the bulky parts) and is written into the guides (docs/fit.md, identify.md, train.md, simulate.md,
own-data.md), experiments/apps/README.md and the index experiments/README.md between
``<!-- apps:<block>:start -->`` and ``<!-- apps:<block>:end -->``.
``tests/test_readme_numbers.py`` checks that the blocks are what the committed JSON renders to, and that the rest
of those sections quotes no other number.

    OMP_NUM_THREADS=1 PYTHONPATH=. python scripts/readme_apps.py          # every run, one at a time, then the blocks
    OMP_NUM_THREADS=1 PYTHONPATH=. python scripts/readme_apps.py --only fit own_fit   # some runs, then the blocks
    PYTHONPATH=. python scripts/readme_apps.py --render                   # the blocks from the committed JSON only

The commands run as ``python -m hybridhyst.cli.<app>`` with this checkout first on ``PYTHONPATH`` (the console
scripts may belong to another install), each in ``--scratch``/<run> (default ``outputs/readme_apps``). This
module and ``readme_apps_render.py`` (the runs and the renderers) import only the standard library at the top, so
the test can render the blocks cheaply.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import shlex
import shutil
import subprocess
import sys
import time
from datetime import datetime, timezone
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
# the runs and the block renderers; the names marked F401 are not used here: kept so that this module still offers them
# (tests/test_readme_numbers.py reads some)
from readme_apps_render import (  # noqa: E402
    COMMAND,  # noqa: F401
    DISCOVER_KEEP,  # noqa: F401
    DOCS,
    EXAMPLE_NAMES,  # noqa: F401
    FIT_KEEP,  # noqa: F401
    FIT_NAMES,  # noqa: F401
    FOLDER,
    IDENTIFY_KEEP,  # noqa: F401
    MAKE_EXAMPLE,  # noqa: F401
    OWN_DATA_DOC,
    OWN_LABELS,  # noqa: F401
    OWN_NAMES,  # noqa: F401
    OWN_OUTPUT,  # noqa: F401
    ROOT,
    SECTION_RUNS,  # noqa: F401
    SPLIT,  # noqa: F401
    TRAIN_KEEP,  # noqa: F401
    Run,
    all_runs,
    block_fit,
    block_identify,
    block_index,
    block_own_data,
    block_simulate,
    block_table,
    block_train,
    g,  # noqa: F401
    load,  # noqa: F401
    measured_note,  # noqa: F401
    own_data_runs,  # noqa: F401
    secs,  # noqa: F401
    wrap,  # noqa: F401
)

README = ROOT / "README.md"
FOLDER_README = FOLDER / "README.md"


def readme_section(text: str, title: str) -> str:
    """The text of README section ``## <title>...`` up to the next ``## `` heading."""
    head = re.search(rf"^## {re.escape(title)}.*$", text, flags=re.M)
    if head is None:
        raise ValueError(f"README has no section '## {title}'")
    rest = text[head.end():]
    nxt = re.search(r"^## ", rest, flags=re.M)
    return rest[: nxt.start()] if nxt else rest


# ----------------------------------------------------------------------------------------------------- running


def _dotted(cfg: dict, key: str):
    for part in key.split("."):
        cfg = cfg.get(part) if isinstance(cfg, dict) else None
    return cfg


def _terminal(stdout: str, run_dir: Path, app: str) -> list[str]:
    """The app's closing summary on the terminal (discover, train), with the run directory written generically."""
    lines = stdout.splitlines()
    first = {"discover": r"^discovery: ", "train": r"^\S+: \d+ epochs"}.get(app)
    if first is None:
        return []
    starts = [i for i, line in enumerate(lines) if re.match(first, line)]
    if not starts:
        return []
    out = []
    for line in lines[starts[-1]:]:
        out.append(line.replace(str(run_dir), f"outputs/{app}/<date>_<time>"))
        if line.strip().startswith(("report:", "run dir:")):
            break
    return out


def execute(run: Run, scratch: Path) -> dict:
    """Run ``run.command`` (as ``python -m hybridhyst.cli.<app>``) in a fresh ``scratch/<name>``; its record."""
    import yaml

    words = shlex.split(run.command)
    app = words[0].removeprefix("hybridhyst-")
    run_dir = (scratch / run.name).resolve()
    shutil.rmtree(run_dir, ignore_errors=True)
    argv = [sys.executable, "-m", f"hybridhyst.cli.{app}", *words[1:], f"hydra.run.dir={run_dir}"]
    env = {**os.environ, "OMP_NUM_THREADS": "1", "PYTHONPATH": os.pathsep.join(
        [str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])])}
    loadavg = [round(v, 2) for v in os.getloadavg()]
    print(f"[{run.name}] {run.command}", flush=True)
    start = time.perf_counter()
    proc = subprocess.run(argv, cwd=ROOT, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - start
    run_dir.mkdir(parents=True, exist_ok=True)
    (run_dir / "stdout.log").write_text(proc.stdout, encoding="utf-8")
    (run_dir / "stderr.log").write_text(proc.stderr, encoding="utf-8")
    if proc.returncode != 0:
        tail = "\n".join(proc.stderr.splitlines()[-15:])
        raise RuntimeError(f"{run.name}: exit code {proc.returncode} ({run_dir}/stderr.log):\n{tail}")
    output = json.loads((run_dir / run.output).read_text(encoding="utf-8"))
    cfg = yaml.safe_load((run_dir / "config.yaml").read_text(encoding="utf-8"))
    print(f"[{run.name}] {wall:.1f} s", flush=True)
    return {
        "command": run.command,
        "measured": {"wall_s": round(wall, 2), "finished_utc": datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M"),
                     "load_average_at_start": loadavg, "cpus": os.cpu_count(), "python": platform.python_version(),
                     "machine": platform.machine()},
        "config": {key: _dotted(cfg, key) for key in run.config},
        "terminal": _terminal(proc.stdout, run_dir, app),
        run.output: {k: output[k] for k in run.keep if k in output},
    }


def save(run: Run, record: dict, scratch: Path) -> None:
    FOLDER.mkdir(parents=True, exist_ok=True)
    (FOLDER / f"{run.name}.json").write_text(json.dumps(record, indent=1, default=str) + "\n", encoding="utf-8")
    if run.files:
        (FOLDER / run.name).mkdir(exist_ok=True)
        for name in run.files:
            shutil.copyfile(scratch / run.name / name, FOLDER / run.name / name)


# ------------------------------------------------------------------------------------------------------ blocks


def in_docs(render):
    """``render`` for a page in docs/: its links to the repository's folders made relative to docs/."""
    def relinked() -> str:
        return render().replace("](experiments/", "](../experiments/")

    relinked.__name__ = render.__name__
    return relinked


# the guide page that holds each block (docs/), and the blocks of the experiments' READMEs
DOC_BLOCKS = {DOCS / "fit.md": {"fit": in_docs(block_fit)},
              DOCS / "identify.md": {"identify": in_docs(block_identify)},
              DOCS / "train.md": {"train": in_docs(block_train)},
              DOCS / "simulate.md": {"simulate": in_docs(block_simulate)},
              OWN_DATA_DOC: {"own_data": in_docs(block_own_data)}}
README_BLOCKS = {name: fn for blocks in DOC_BLOCKS.values() for name, fn in blocks.items()}  # every guide block
FOLDER_BLOCKS = {"table": block_table}
INDEX = ROOT / "experiments" / "README.md"
INDEX_BLOCKS = {"index": block_index}
BLOCK_FILES = (*DOC_BLOCKS.items(), (FOLDER_README, FOLDER_BLOCKS), (INDEX, INDEX_BLOCKS))


def markers(name: str) -> tuple[str, str]:
    return f"<!-- apps:{name}:start -->", f"<!-- apps:{name}:end -->"


def blocks_in(text: str) -> dict[str, str]:
    """{name: content} of every ``<!-- apps:<name>:start -->`` ... ``end`` block of ``text`` (content stripped)."""
    found = re.findall(r"<!-- apps:(\w+):start -->\n(.*?)\n<!-- apps:\1:end -->", text, flags=re.S)
    return {name: body for name, body in found}


def replace_blocks(text: str, rendered: dict[str, str]) -> str:
    for name, body in rendered.items():
        start, end = markers(name)
        if text.count(start) != 1 or text.count(end) != 1:
            raise ValueError(f"expected one {start} ... {end} pair")
        head, rest = text.split(start, 1)
        text = head + start + "\n" + body + "\n" + end + rest.split(end, 1)[1]
    return text


def render_all() -> None:
    for path, blocks in BLOCK_FILES:
        text = path.read_text(encoding="utf-8")
        path.write_text(replace_blocks(text, {name: fn() for name, fn in blocks.items()}), encoding="utf-8")
        print(f"blocks rewritten: {path.relative_to(ROOT)} ({', '.join(blocks)})", flush=True)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--only", nargs="+", metavar="RUN", help="run only these (names of experiments/apps/*.json)")
    parser.add_argument("--render", action="store_true", help="no runs: rewrite the blocks from the committed JSON")
    parser.add_argument("--scratch", type=Path, default=ROOT / "outputs" / "readme_apps", help="run directories")
    args = parser.parse_args(argv)
    if not args.render:
        runs = {r.name: r for r in all_runs()}
        unknown = sorted(set(args.only or ()) - set(runs))
        if unknown:
            parser.error(f"unknown run(s) {unknown}; choose from {sorted(runs)}")
        for name in args.only or list(runs):  # one at a time: the machine is shared
            save(runs[name], execute(runs[name], args.scratch), args.scratch)
    render_all()


if __name__ == "__main__":
    main()
