"""Each wear effect has one home: its id and the names of its wear_monitor parameters appear (as whole words) in no
file of guide_health/ but its own module (models/wear/effects/<id>.py), the registry (models/wear/effects/
registry.py) and the allow-list below, each entry with the effects it may name and why. Everything else reaches an
effect through the registry's interface (its roles and the methods of models/wear/effects/base.Effect), so a file
that names an effect by hand fails here (bench/effect_mentions.py prints the same count per effect)."""
import re
from pathlib import Path

import pytest

from guide_health.models.wear.effects import registry

PACKAGE = Path(__file__).resolve().parents[1] / "guide_health"
HOME = "models/wear/effects/{}.py"
REGISTRY = "models/wear/effects/registry.py"

#: files outside an effect's home that may still name it: {file: (the effects it may name, why)}
ALLOWED: dict[str, tuple[set[str], str]] = {}


def effect_pattern(effect) -> re.Pattern:
    """Its id or one of its wear_monitor parameter names, as a whole word."""
    words = {effect.id} | {p.name for p in effect.parameters}
    return re.compile(r"\b(" + "|".join(map(re.escape, sorted(words))) + r")\b")


def named_outside_home(texts: dict[str, str]) -> list[tuple[str, str]]:
    """(file, effect id) of every file in ``texts`` ({path relative to guide_health/: text}) that names an effect
    outside its home, the registry and the allow-list."""
    found = []
    for effect in registry.EFFECTS:
        pattern = effect_pattern(effect)
        for path, text in texts.items():
            if path in (HOME.format(effect.id), REGISTRY):
                continue
            if effect.id in ALLOWED.get(path, ((), ""))[0]:
                continue
            if pattern.search(text):
                found.append((path, effect.id))
    return found


def _package_texts() -> dict[str, str]:
    return {str(p.relative_to(PACKAGE)): p.read_text() for p in sorted(PACKAGE.rglob("*.py"))
            if "__pycache__" not in p.parts}


def test_no_file_names_an_effect_outside_its_home():
    assert named_outside_home(_package_texts()) == []


def test_every_effect_has_its_module_and_the_allow_list_is_real():
    texts = _package_texts()
    for effect in registry.EFFECTS:
        assert effect_pattern(effect).search(texts[HOME.format(effect.id)]), effect.id
    for path, (ids, reason) in ALLOWED.items():
        assert reason and path in texts, path
        # an entry (or an effect of it) no longer needed goes: the list only shrinks
        named = {e.id for e in registry.EFFECTS if effect_pattern(e).search(texts[path])}
        assert named == set(ids), (path, sorted(set(ids) - named), sorted(named - set(ids)))


@pytest.mark.parametrize("text", ["x = e.thermal_drift_m_per_k\n", "# the running_in effect\n",
                                  'ids = ("load_along_rail",)\n'])
def test_the_check_finds_an_effect_named_by_hand(text):
    assert named_outside_home({"models/wear/new_module.py": text}) != []
    assert named_outside_home({"models/wear/new_module.py": "x = GAUGE_TEMPERATURE.correction_m(e, 1.0)\n"}) == []


def test_the_roles_are_the_effects_that_implement_them():
    """The material and duty factors are exactly the effects whose module gives those forms."""
    from guide_health.models.wear.effects.base import Effect

    material = [e for e in registry.EFFECTS if type(e).rate_factor is not Effect.rate_factor]
    duty = [e for e in registry.EFFECTS if type(e).live_duty_factor is not Effect.live_duty_factor]
    assert sorted(e.id for e in material) == sorted(e.id for e in registry.MATERIAL_FACTORS)
    assert sorted(e.id for e in duty) == sorted(e.id for e in registry.DUTY_FACTORS) == sorted(
        registry.DUTY_EFFECT_IDS)
    assert all(e.rate_row for e in registry.MATERIAL_FACTORS + registry.DUTY_FACTORS)
    scenario = [e for e in registry.EFFECTS if any(getattr(type(e), name) is not getattr(Effect, name) for name in (
        "scenario_load_exponent", "scenario_rate_factor", "scenario_dln"))]
    assert sorted(e.id for e in scenario) == sorted(e.id for e in registry.SCENARIO_FACTORS)
    assert all(e.rate_row for e in registry.SCENARIO_FACTORS)
