"""Write the layer diagram of docs/architecture.md from the import contract in pyproject.toml.

The layers are read from the ``[[tool.importlinter.contracts]]`` entry of type ``layers`` (the contract that
``lint-imports`` checks, ``tests/test_layers.py``) and written between ``<!-- layers:start -->`` and
``<!-- layers:end -->``. ``tests/test_docs.py`` fails when the diagram there is not what this script writes.

    python scripts/docs_layers.py           # rewrite the diagram
    python scripts/docs_layers.py --check   # exit 1 when it is stale
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PYPROJECT = ROOT / "pyproject.toml"
TARGET = ROOT / "docs" / "architecture.md"
START, END = "<!-- layers:start -->", "<!-- layers:end -->"


def _contract(text: str) -> dict:
    """The layers contract of pyproject.toml ``text`` (tomllib where it exists, Python >= 3.11)."""
    try:
        import tomllib
    except ModuleNotFoundError:  # Python 3.10: the one list this script needs, read by a pattern
        block = re.search(r'type\s*=\s*"layers".*?layers\s*=\s*\[(.*?)\]', text, flags=re.S)
        if block is None:
            raise ValueError("pyproject.toml has no importlinter contract of type 'layers'") from None
        return {"layers": re.findall(r'"([^"]+)"', block.group(1))}
    contracts = tomllib.loads(text).get("tool", {}).get("importlinter", {}).get("contracts", [])
    found = [c for c in contracts if c.get("type") == "layers"]
    if len(found) != 1:
        raise ValueError(f"pyproject.toml has {len(found)} importlinter contracts of type 'layers', expected 1")
    return found[0]


def layers(text: str | None = None) -> list[list[str]]:
    """The layers, top first, each a list of the packages on it (``"a | b"``: two that do not import each other)."""
    contract = _contract(PYPROJECT.read_text(encoding="utf-8") if text is None else text)
    return [[name.strip() for name in layer.split("|")] for layer in contract["layers"]]


def render(text: str | None = None) -> str:
    """The diagram: one line per layer, top first, ``↓`` between them."""
    rows = [" | ".join(layer) for layer in layers(text)]
    width = max(len(r) for r in rows)
    lines = []
    for i, row in enumerate(rows):
        lines.append(row.center(width).rstrip())
        if i < len(rows) - 1:
            lines.append("↓".center(width).rstrip())
    return "\n".join(["```text", *lines, "```"])


def replaced(doc: str, body: str) -> str:
    if doc.count(START) != 1 or doc.count(END) != 1:
        raise ValueError(f"{TARGET.relative_to(ROOT)} needs one {START} ... {END} pair")
    head, rest = doc.split(START, 1)
    return head + START + "\n" + body + "\n" + END + rest.split(END, 1)[1]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--check", action="store_true", help="exit 1 when the diagram is stale; write nothing")
    args = parser.parse_args(argv)
    doc = TARGET.read_text(encoding="utf-8")
    new = replaced(doc, render())
    if args.check:
        if new != doc:
            print(f"{TARGET.relative_to(ROOT)}: the layer diagram is stale; run python scripts/docs_layers.py")
            return 1
        return 0
    TARGET.write_text(new, encoding="utf-8")
    print(f"layer diagram written: {TARGET.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
