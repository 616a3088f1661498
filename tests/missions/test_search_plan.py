"""The search script's planning, without a vehicle: the area files it reads, the patterns it
plans and the coverage it measures (missions/search.py)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from missions.common import MissionError
from missions.search import coverage, expanding_square, lawnmower, load_area, longest_edge_angle

BOX = [(0.0, 0.0), (0.0, 60.0), (50.0, 60.0), (50.0, 0.0)]
TRIANGLE = [(0.0, 0.0), (10.0, 80.0), (70.0, 20.0)]
RING_LAT_LON = [(41.7702, 123.4295), (41.7702, 123.4305), (41.7708, 123.4305), (41.7708, 123.4295)]


@pytest.mark.parametrize("polygon", [BOX, TRIANGLE])
@pytest.mark.parametrize("spacing_m", [10.0, 7.0])
def test_lawnmower_covers_the_polygon_with_lines_at_most_one_spacing_apart(
        polygon: list[tuple[float, float]], spacing_m: float) -> None:
    pattern = lawnmower(polygon, spacing_m)
    assert coverage(polygon, pattern, spacing_m) > 0.995
    assert coverage(polygon, pattern, 0.5 * spacing_m) < 0.8  # the sweep width matters: lines are apart


def test_lawnmower_runs_along_the_longest_edge_and_alternates() -> None:
    assert longest_edge_angle(BOX) == pytest.approx(math.pi / 2)  # the 60 m edge runs east
    pattern = lawnmower(BOX, 10.0)
    assert len(pattern) == 10  # five lines, two ends each
    norths = sorted({round(n, 6) for n, _ in pattern})
    assert norths == pytest.approx([5.0, 15.0, 25.0, 35.0, 45.0])
    assert [(round(n), round(e)) for n, e in pattern[:4]] == [(5, 0), (5, 60), (15, 60), (15, 0)]  # from home
    far = lawnmower(BOX, 10.0, start=(50.0, 60.0))
    assert [(round(n), round(e)) for n, e in far[:2]] == [(45, 60), (45, 0)]


def test_missing_a_line_shows_in_the_coverage() -> None:
    pattern = lawnmower(BOX, 10.0)
    assert 0.75 < coverage(BOX, pattern[:8], 10.0) < 0.85


def test_expanding_square_covers_the_polygon() -> None:
    pattern = expanding_square(BOX, 10.0)
    assert pattern[0] == pytest.approx((25.0, 30.0))  # starts at the centre
    assert coverage(BOX, pattern, 10.0) > 0.97  # with track spacing = sweep width the ring corners stay open


def _write(tmp_path: Path, name: str, data: object) -> Path:
    path = tmp_path / name
    path.write_text(json.dumps(data), encoding="utf-8")
    return path


def test_reads_a_qgc_plan_survey_polygon_or_its_geofence(tmp_path: Path) -> None:
    survey = {"fileType": "Plan", "version": 1, "mission": {"items": [
        {"type": "SimpleItem", "command": 16},
        {"type": "ComplexItem", "complexItemType": "survey", "polygon": [list(p) for p in RING_LAT_LON]}]},
        "geoFence": {"polygons": []}}
    assert load_area(_write(tmp_path, "a.plan", survey)) == RING_LAT_LON
    fence = {"fileType": "Plan", "mission": {"items": []}, "geoFence": {"polygons": [
        {"inclusion": False, "polygon": [[0, 0], [0, 1], [1, 1]]},
        {"inclusion": True, "polygon": [list(p) for p in RING_LAT_LON]}]}}
    assert load_area(_write(tmp_path, "b.plan", fence)) == RING_LAT_LON


def test_reads_geojson_in_lon_lat_order(tmp_path: Path) -> None:
    ring = [[lon, lat] for lat, lon in [*RING_LAT_LON, RING_LAT_LON[0]]]  # closed, lon/lat
    polygon = {"type": "Polygon", "coordinates": [ring]}
    for data in (polygon, {"type": "Feature", "properties": {}, "geometry": polygon},
                 {"type": "FeatureCollection", "features": [
                     {"type": "Feature", "geometry": {"type": "Point", "coordinates": [0, 0]}},
                     {"type": "Feature", "geometry": polygon}]}):
        assert load_area(_write(tmp_path, "a.geojson", data)) == RING_LAT_LON


@pytest.mark.parametrize(("content", "message"), [
    ("{not json", "cannot read the area"),
    (json.dumps({"fileType": "Plan", "mission": {"items": []}}), "no search polygon found"),
    (json.dumps({"type": "Point", "coordinates": [1, 2]}), "no search polygon found"),
    (json.dumps({"type": "Polygon", "coordinates": [[[1, 2], [3, 4], [1, 2]]]}), "at least 3 vertices"),
    (json.dumps({"type": "Polygon", "coordinates": [[[1, 200], [3, 4], [5, 6]]]}), "on the globe"),
    (json.dumps([1, 2]), "not a QGC plan or GeoJSON"),
])
def test_a_bad_area_file_is_a_clear_error(tmp_path: Path, content: str, message: str) -> None:
    path = tmp_path / "area.json"
    path.write_text(content, encoding="utf-8")
    with pytest.raises(MissionError, match=message):
        load_area(path)
    with pytest.raises(MissionError, match="cannot read"):
        load_area(tmp_path / "missing.geojson")
