"""Where a study writes: tables (CSV + Markdown), figures (PNG), a results page, and publishing.

Every file goes through ``atomic_write``. ``results.md`` is assembled from the sections a study adds, in
order; ``publish(dest)`` copies the run's artefacts into ``experiments/<study>/`` and replaces the block
between ``<!-- results:start -->`` and ``<!-- results:end -->`` of that folder's README with ``results.md``,
so every number in an experiment README comes from the command written above it.
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pandas as pd

from ..files import atomic_write, write_json

START, END = "<!-- results:start -->", "<!-- results:end -->"
ARTEFACTS = ("*.csv", "*.png", "results.md", "summary.json")


def markdown_table(frame: pd.DataFrame, floatfmt: str = ".4g") -> str:
    """A GitHub Markdown table of ``frame`` (index dropped; floats formatted with ``floatfmt``)."""
    def cell(v) -> str:
        if isinstance(v, float):
            return "—" if v != v else format(v, floatfmt)
        return str(v)

    cols = [str(c) for c in frame.columns]
    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    lines += ["| " + " | ".join(cell(v) for v in row) + " |" for row in frame.itertuples(index=False)]
    return "\n".join(lines)


class StudyOutput:
    """A study's output directory and its growing ``results.md``."""

    def __init__(self, directory: Path | str, title: str):
        self.dir = Path(directory)
        self.dir.mkdir(parents=True, exist_ok=True)
        self.sections: list[str] = [f"### {title}\n"]

    def text(self, markdown: str) -> None:
        """Add a paragraph (Markdown) to ``results.md``."""
        self.sections.append(markdown.strip() + "\n")

    def table(self, name: str, frame: pd.DataFrame, caption: str = "", floatfmt: str = ".4g") -> Path:
        """Write ``<name>.csv`` and add the table (with ``caption`` above it) to ``results.md``."""
        path = atomic_write(self.dir / f"{name}.csv", frame.to_csv(index=False))
        head = f"**{caption}** ([{name}.csv]({name}.csv))\n\n" if caption else ""
        self.sections.append(head + markdown_table(frame, floatfmt) + "\n")
        return path

    def csv(self, name: str, frame: pd.DataFrame, caption: str) -> Path:
        """Write ``<name>.csv`` only (a table too long to show) and link it from ``results.md``."""
        path = atomic_write(self.dir / f"{name}.csv", frame.to_csv(index=False))
        self.sections.append(f"[{name}.csv]({name}.csv): {caption}\n")
        return path

    def figure(self, name: str, fig, caption: str = "") -> Path:
        """Save a matplotlib figure as ``<name>.png`` (closed afterwards) and show it in ``results.md``."""
        import matplotlib.pyplot as plt

        path = atomic_write(self.dir / f"{name}.png", lambda p: fig.savefig(p, dpi=110, bbox_inches="tight",
                                                                             format="png"))
        plt.close(fig)
        self.sections.append(f"![{caption or name}]({name}.png)\n" + (f"\n*{caption}*\n" if caption else ""))
        return path

    def finish(self, summary: dict) -> dict:
        """Write ``results.md`` and ``summary.json``; return ``summary``."""
        atomic_write(self.dir / "results.md", "\n".join(self.sections))
        write_json(self.dir / "summary.json", summary)
        return summary

    def publish(self, dest: Path | str) -> Path:
        """Copy the artefacts to ``dest`` and put ``results.md`` between the README's result markers.

        A README without the markers gets them appended; a missing README is created.
        """
        dest = Path(dest)
        dest.mkdir(parents=True, exist_ok=True)
        for pattern in ARTEFACTS:
            for src in self.dir.glob(pattern):
                shutil.copyfile(src, dest / src.name)
        block = f"{START}\n" + (self.dir / "results.md").read_text(encoding="utf-8") + f"\n{END}"
        readme = dest / "README.md"
        text = readme.read_text(encoding="utf-8") if readme.exists() else ""
        if START in text and END in text:
            text = re.sub(re.escape(START) + r".*?" + re.escape(END), lambda _: block, text, flags=re.S)
        else:
            text = text.rstrip() + ("\n\n" if text else "") + "## Results (generated)\n\n" + block + "\n"
        atomic_write(readme, text)
        return dest
