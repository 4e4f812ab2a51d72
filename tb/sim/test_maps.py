"""Map and scenario loading: the bundled maps parse, bad files name their line."""

import re
from pathlib import Path

import numpy as np
import pytest

from navcores.models.maps import MapFormatError, load_map, load_scenarios

MAPS = Path(__file__).resolve().parents[2] / "maps"


@pytest.mark.parametrize("name", sorted(p.name for p in MAPS.glob("*.map")))
def test_bundled_maps_parse(name):
    grid = load_map(MAPS / name)
    text = (MAPS / name).read_text().splitlines()
    assert grid.shape == (int(text[1].split()[1]), int(text[2].split()[1]))
    assert grid.sum() == sum(row.count("@") + row.count("T") for row in text[4:])


@pytest.mark.parametrize("name", sorted(p.name for p in MAPS.glob("*.scen")))
def test_bundled_scenarios_parse(name):
    grid = load_map(MAPS / (re.sub(r"(-even-\d+|-longest)?\.scen$", "", name) + ".map"))   # the map it belongs to
    scen = load_scenarios(MAPS / name, grid)
    assert scen and all(not grid[s.start] and not grid[s.goal] for s in scen)


GOOD = "type octile\nheight 2\nwidth 3\nmap\n.@.\n...\n"


@pytest.mark.parametrize("text,line,message", [
    ("", 1, "type octile"),
    ("type octile\nheight x\nwidth 3\nmap\n", 2, "height N"),
    ("type octile\nheight 2\nwidth 3\nmop\n.@.\n...\n", 4, "'map'"),
    ("type octile\nheight 2\nwidth 3\nmap\n.@.\n..\n", 6, "2 cells"),
    ("type octile\nheight 2\nwidth 3\nmap\n.@.\n.x.\n", 6, "unknown terrain 'x'"),
    ("type octile\nheight 3\nwidth 3\nmap\n.@.\n...\n", 7, "2 of 3 rows"),
    (GOOD + "...\n", 7, "after the last"),
])
def test_bad_map_names_line(tmp_path, text, line, message):
    path = tmp_path / "bad.map"
    path.write_text(text)
    with pytest.raises(MapFormatError, match=message) as info:
        load_map(path)
    assert info.value.line == line and str(info.value).startswith(f"{path}:{line}:")


def test_scenario_checks(tmp_path):
    grid_path = tmp_path / "m.map"
    grid_path.write_text(GOOD)
    grid = load_map(grid_path)
    scen = tmp_path / "m.scen"
    scen.write_text("version 1\n0\tm\t3\t2\t0\t0\t2\t1\t3\n")
    assert load_scenarios(scen, grid)[0].goal == (1, 2)
    for bad, why in [("0\tm\t3\t2\t1\t0\t2\t1\t3", "start \\(1, 0\\) is on an obstacle"),
                     ("0\tm\t3\t2\t0\t0\t5\t1\t3", "goal \\(5, 1\\) outside"),
                     ("0\tm\t4\t2\t0\t0\t2\t1\t3", "4x2 map"),
                     ("0\tm\t3\t2\t0\t0\t2\t1", "9 fields"),
                     ("0\tm\t3\t2\tq\t0\t2\t1\t3", "bad number")]:
        scen.write_text("version 1\n\n" + bad + "\n")
        with pytest.raises(MapFormatError, match=why) as info:
            load_scenarios(scen, grid)
        assert info.value.line == 3


def test_ascii_and_images_agree(tmp_path):
    from PIL import Image

    from navcores.models.maps import load_grid
    ref = load_map(MAPS / "room-32-32-4.map")
    (tmp_path / "m.txt").write_text("\n".join("".join("#" if v else "." for v in row) for row in ref) + "\n\n")
    img = Image.fromarray(np.where(ref, 0, 255).astype(np.uint8))
    img.save(tmp_path / "m.png")
    img.save(tmp_path / "m.pgm")
    for name in ("m.txt", "m.png", "m.pgm"):
        assert (load_grid(tmp_path / name) == ref).all(), name
    assert (load_grid(MAPS / "room-32-32-4.map") == ref).all()


@pytest.mark.parametrize("name,text,message", [
    ("a.txt", "..#\n.#\n", "2:.*2 cells"),
    ("b.txt", "..#\n.x.\n", "2:.*unknown cell 'x'"),
    ("c.txt", "\n", "1:.*empty"),
    ("d.png", "not an image", "not a readable image"),
    ("e.xyz", "", "unknown map format"),
])
def test_bad_grids(tmp_path, name, text, message):
    from navcores.models.maps import load_grid
    (tmp_path / name).write_text(text)
    with pytest.raises(MapFormatError, match=message):
        load_grid(tmp_path / name)
