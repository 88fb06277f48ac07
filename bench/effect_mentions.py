"""Per effect of the registry (models/wear/effects/registry.py), the files of guide_health/ that mention it: its
id or one of its wear_monitor parameter names, as a whole word. The target is its own module and the registry
(plus tests, which are not counted here); a file beyond those restates by hand something the registry derives.

    PYTHONPATH=$PWD python bench/effect_mentions.py            # the table of this tree
    PYTHONPATH=/work/main python bench/effect_mentions.py      # another tree, for before/after
    ... --files                                                # and the files of each effect
"""
from __future__ import annotations

import argparse
import re
from pathlib import Path


def mentions(package: Path) -> dict[str, list[str]]:
    """{effect id: the files of ``package`` (relative to its parent) that mention the id or a parameter name}."""
    from guide_health.models.wear.effects.registry import EFFECTS

    texts = {str(p.relative_to(package.parent)): p.read_text() for p in sorted(package.rglob("*.py"))
             if "__pycache__" not in p.parts}
    found = {}
    for effect in EFFECTS:
        words = {effect.id} | {p.name for p in effect.parameters}
        pattern = re.compile(r"\b(" + "|".join(map(re.escape, sorted(words))) + r")\b")
        found[effect.id] = [path for path, text in texts.items() if pattern.search(text)]
    return found


def main(argv=None) -> None:
    import guide_health

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--files", action="store_true", help="list the files of each effect")
    args = ap.parse_args(argv)
    found = mentions(Path(guide_health.__file__).parent)
    for effect, files in found.items():
        print(f"{effect:24s} {len(files):3d}")
        if args.files:
            for path in files:
                print(f"    {path}")


if __name__ == "__main__":
    main()
