import math
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from companion.param_table import all_param_defs
from companion.params import ParamDef, ParamError, ParamStore

SPEED = ParamDef("WP_SPEED", 5.0, 0.0, 10.0, "m/s", "Cruise speed in AUTO.")
COUNT = ParamDef("USV_BOTTLES", 4, 0, 4, "", "Sample bottles.", is_int=True)


def test_refused_values_keep_the_old_value_and_say_why() -> None:
    store = ParamStore([SPEED, COUNT])
    with pytest.raises(ParamError, match=r"WP_SPEED: 12 is out of range \[0, 10\] m/s"):
        store.set("WP_SPEED", 12)
    with pytest.raises(ParamError, match="not a finite number"):
        store.set("WP_SPEED", math.nan)
    with pytest.raises(ParamError, match="expected an integer"):
        store.set("USV_BOTTLES", 2.5)
    with pytest.raises(ParamError, match="unknown parameter"):
        store.set("NOPE", 1)
    assert store.get("WP_SPEED") == 5.0
    assert store.get("USV_BOTTLES") == 4


@given(st.floats(allow_nan=True, allow_infinity=True))
def test_any_float_is_either_stored_in_range_or_refused(value: float) -> None:
    store = ParamStore([SPEED])
    try:
        stored = store.set("WP_SPEED", value)
    except ParamError:
        assert store.get("WP_SPEED") == 5.0
    else:
        assert 0.0 <= stored <= 10.0 and stored == store.get("WP_SPEED")


def test_values_persist_atomically_across_restarts(tmp_path: Path) -> None:
    path = tmp_path / "params.toml"
    store = ParamStore([SPEED, COUNT], path)
    store.set("WP_SPEED", 3.5)
    store.set("USV_BOTTLES", 2)
    assert not list(tmp_path.glob(".params.toml.*")), "temporary file left behind"
    again = ParamStore([SPEED, COUNT], path)
    assert again.get("WP_SPEED") == 3.5 and again.get("USV_BOTTLES") == 2


def test_a_corrupt_saved_file_falls_back_to_defaults_with_a_warning(tmp_path: Path) -> None:
    path = tmp_path / "params.toml"
    path.write_text("WP_SPEED = 99\nGARBAGE ===\n")
    store = ParamStore([SPEED], path)
    assert store.get("WP_SPEED") == 5.0
    assert store.load_warnings and "cannot read" in store.load_warnings[0]


def test_listeners_hear_changes_only() -> None:
    store = ParamStore([SPEED])
    heard: list[tuple[str, float]] = []
    store.add_listener(lambda n, v: heard.append((n, v)))
    store.set("WP_SPEED", 5.0)
    store.set("WP_SPEED", 6.0)
    assert heard == [("WP_SPEED", 6.0)]


def test_product_table_is_valid_and_documents_every_parameter() -> None:
    defs = all_param_defs()
    store = ParamStore(defs)
    names = store.names()
    assert len(set(names)) == len(names)
    doc = store.markdown()
    for d in defs:
        assert f"`{d.name}`" in doc
        assert d.description
    assert store.index_of(names[-1]) == len(names) - 1


def test_bad_definitions_are_caught_at_import_time() -> None:
    with pytest.raises(ValueError, match="16 ASCII"):
        ParamDef("A_VERY_LONG_PARAMETER_NAME", 0, 0, 1, "", "x")
    with pytest.raises(ValueError, match="outside"):
        ParamDef("X", 5, 0, 1, "", "x")
