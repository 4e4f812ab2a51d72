"""ROS map_server / nav2 maps (models/maps.py): nav2's semantics, cell by cell.

Every expected value below is worked out by hand from nav2's map_io.cpp
(loadMapFromFile): shade = mean of the channels / 255, occ = 1 - shade (or
shade with negate), trinary: occ > occupied_thresh -> 100, occ <
free_thresh -> 0, else -1; scale: not opaque -> -1, between the thresholds
rint((occ - free) / (occ_th - free) * 100); raw: round(shade * 255) when
0..100, else -1.  The OccupancyGrid's row 0 is the image's bottom row.
"""

import math
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from navcores.models.maps import (MapFormatError, MapFrame, load, load_grid, load_map, save_map, save_ros)

ROOT = Path(__file__).resolve().parents[2]


def pgm(path, rows):
    a = np.array(rows, dtype=np.uint8)
    path.write_bytes(f"P5\n{a.shape[1]} {a.shape[0]}\n255\n".encode() + a.tobytes())
    return path


def yaml(path, image, **kw):
    fields = {"image": image, "resolution": 0.05, "origin": "[0.0, 0.0, 0.0]", "negate": 0,
              "occupied_thresh": 0.65, "free_thresh": 0.196, **kw}
    path.write_text("".join(f"{k}: {v}\n" for k, v in fields.items() if v is not None))
    return path


# grey values around the thresholds 0.65 / 0.196 (occ = 1 - v / 255):
#   v = 0: occ 1.0 -> 100;  89: 0.65098 -> 100;  90: 0.64706 -> -1;  128: 0.49804 -> -1
#   205: 0.196078 (not < 0.196) -> -1 (map_saver's "unknown" grey);  206: 0.19216 -> 0;  254 -> 0;  255 -> 0
GREYS = [[0, 89, 90, 128], [205, 206, 254, 255]]
TRINARY = [[100, 100, -1, -1], [-1, 0, 0, 0]]                 # image rows as drawn (top first)
# negate: occ = v / 255:  0 -> 0 (free); 89: 0.349 -> -1; 90: 0.353 -> -1; 128: 0.502 -> -1;
#   205: 0.804 -> 100; 206 -> 100; 254 -> 100; 255 -> 100
NEGATED = [[0, -1, -1, -1], [100, 100, 100, 100]]


def test_trinary_by_hand(tmp_path):
    pgm(tmp_path / "m.pgm", GREYS)
    m = load(yaml(tmp_path / "m.yaml", "m.pgm"))
    assert m.occupancy.tolist() == TRINARY[::-1]               # nav2's order: the bottom image row first
    assert m.obstacle.tolist() == [[True, True, True, True], [True, False, False, False]]
    free = load(tmp_path / "m.yaml", unknown="free")
    assert free.obstacle.tolist() == [[True, True, False, False], [False, False, False, False]]
    neg = load(yaml(tmp_path / "n.yaml", "m.pgm", negate="true"))
    assert neg.occupancy.tolist() == NEGATED[::-1]
    assert load(yaml(tmp_path / "n1.yaml", "m.pgm", negate=1)).occupancy.tolist() == NEGATED[::-1]


def test_colour_shade_is_the_channel_mean(tmp_path):
    # (30, 60, 90): mean 60, occ 0.76471 -> 100;  (200, 210, 220): mean 210, occ 0.17647 -> 0
    # (255, 0, 0): mean 85, occ 0.66667 -> 100;  (250, 250, 100): mean 200, occ 0.21569 -> -1
    rgb = np.array([[[30, 60, 90], [200, 210, 220]], [[255, 0, 0], [250, 250, 100]]], dtype=np.uint8)
    Image.fromarray(rgb, "RGB").save(tmp_path / "c.png")
    m = load(yaml(tmp_path / "c.yaml", "c.png"))
    assert m.occupancy.tolist() == [[100, -1], [100, 0]]


def test_alpha_as_nav2_treats_it(tmp_path):
    # grey + alpha.  trinary averages the alpha in as a 4th channel:
    #   (254, a 255): (3*254 + 255) / 4 = 254.25 -> occ 0.00294 -> 0
    #   (254, a 0):   (3*254 + 0) / 4 = 190.5 -> occ 0.25294 -> -1 (free_thresh 0.196)
    #   (0, a 0):     0 -> occ 1 -> 100;  (254, a 128): 222.5 -> occ 0.12745 -> 0
    la = np.array([[[254, 255], [254, 0]], [[0, 0], [254, 128]]], dtype=np.uint8)
    Image.fromarray(la, "LA").save(tmp_path / "a.png")
    tri = load(yaml(tmp_path / "t.yaml", "a.png"))
    assert tri.occupancy.tolist() == [[100, 0], [0, -1]]
    # scale: only an opaque pixel has a value (254 opaque -> occ 0.0039 -> 0), the rest -1
    sc = load(yaml(tmp_path / "s.yaml", "a.png", mode="scale"))
    assert sc.occupancy.tolist() == [[-1, -1], [0, -1]]


def test_scale_and_raw_by_hand(tmp_path):
    # scale, thresholds 0.65 / 0.25: v = 128: occ 0.49804 -> rint(62.01) = 62;  100: occ 0.60784 -> rint(89.46) = 89
    #   150: occ 0.41176 -> rint(40.44) = 40;  0 -> 100;  255 -> 0;  160: occ 0.37255 -> rint(30.64) = 31
    pgm(tmp_path / "s.pgm", [[128, 100, 150], [0, 255, 160]])
    sc = load(yaml(tmp_path / "s.yaml", "s.pgm", mode="scale", free_thresh=0.25))
    assert sc.occupancy.tolist() == [[100, 0, 31], [62, 89, 40]]
    assert sc.obstacle.tolist() == [[False, False, False], [True, False, False]]   # lethal: 100 only
    # raw: the value itself when 0..100: 50 -> 50, 100 -> 100, 101 -> -1, 0 -> 0, 255 -> -1, 7 -> 7
    pgm(tmp_path / "r.pgm", [[50, 100, 101], [0, 255, 7]])
    raw = load(yaml(tmp_path / "r.yaml", "r.pgm", mode="raw"))
    assert raw.occupancy.tolist() == [[0, -1, 7], [50, 100, -1]]
    assert raw.obstacle.tolist() == [[False, True, True], [False, True, False]]


def test_frame_rows_flipped_origin_yaw(tmp_path):
    (tmp_path / "img").mkdir()
    pgm(tmp_path / "img" / "f.pgm", [[0, 254, 254], [254, 254, 254]])
    m = load(yaml(tmp_path / "f.yaml", "img/f.pgm", resolution=0.5, origin="[1.0, -2.0, 0.0]"))
    f = m.frame
    assert (f.height, f.width, f.resolution, f.origin, f.y_up) == (2, 3, 0.5, (1.0, -2.0, 0.0), True)
    # the lower-left pixel (image row 1, col 0) has its corner at the origin: centre (1.25, -1.75)
    assert np.allclose(f.cell_to_xy(1, 0), (1.25, -1.75))
    # the occupied top-left pixel: row 0 -> y = -2 + 1.5 * 0.5 = -1.25
    assert np.allclose(f.cell_to_xy(0, 0), (1.25, -1.25)) and m.obstacle[0, 0]
    assert [int(v) for v in f.xy_to_cell(1.3, -1.1)] == [0, 0]
    assert [int(v) for v in f.xy_to_cell(2.4, -1.9)] == [1, 2]
    r, c = f.xy_to_cell(0.9, -1.9)
    assert c < 0                                                   # left of the map
    # yaw: the image's x axis along the map's y axis
    rot = MapFrame(2, 3, 0.5, (1.0, -2.0, math.pi / 2), True)
    assert np.allclose(rot.cell_to_xy(1, 0), (1.0 - 0.25, -2.0 + 0.25))
    assert np.allclose(rot.cell_to_xy(1, 2), (1.0 - 0.25, -2.0 + 1.25))
    for rc in ((0, 0), (1, 2), (0, 1)):
        assert [int(v) for v in rot.xy_to_cell(*rot.cell_to_xy(*rc))] == list(rc)
    # an absolute image path
    m2 = load(yaml(tmp_path / "abs.yaml", str(tmp_path / "img" / "f.pgm")))
    assert (m2.obstacle == m.obstacle).all()


def test_bundled_map_converted_both_ways(tmp_path):
    grid = load_map(ROOT / "maps" / "room-32-32-4.map")
    ros = load(ROOT / "maps" / "room-32-32-4.yaml")
    assert (ros.obstacle == grid).all() and ros.frame.resolution == 0.1
    assert ros.frame.origin == (-1.6, -1.6, 0.0)
    assert set(np.unique(ros.occupancy).tolist()) == {0, 100}
    assert (ros.occupancy[::-1] == 100).tolist() == grid.tolist()
    # .map -> ROS -> grid, and ROS -> .map -> grid
    save_ros(tmp_path / "r.yaml", grid, 0.05, (2.0, 3.0, 0.5))
    back = load(tmp_path / "r.yaml")
    assert (back.obstacle == grid).all() and back.frame.origin == (2.0, 3.0, 0.5)
    save_map(tmp_path / "r.map", ros.obstacle)
    assert (load_grid(tmp_path / "r.map") == grid).all()


@pytest.mark.parametrize("text,message", [
    ("image: m.pgm\nresolution: 0.1\n", "missing origin, occupied_thresh, free_thresh, negate"),
    ("image: m.pgm\nresolution: [0.1\n", "not valid YAML"),
    ("- 1\n- 2\n", "expected a YAML mapping"),
    ("{REST}origin: [0, 0]\n", "'origin' must be \\[x, y, yaw\\]"),
    ("{REST}origin: [0, .nan, 0]\n", "'origin' must be"),
    ("image: m.pgm\nresolution: 0\norigin: [0, 0, 0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.2\n",
     "resolution 0.0: must be > 0"),
    ("image: m.pgm\nresolution: fine\norigin: [0, 0, 0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.2\n",
     "'resolution' must be a number"),
    ("image: m.pgm\nresolution: .inf\norigin: [0, 0, 0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.2\n",
     "'resolution' must be finite"),
    ("image: m.pgm\nresolution: 1\norigin: [0, 0, 0]\nnegate: 0\noccupied_thresh: 0.2\nfree_thresh: 0.65\n",
     "0 <= free_thresh <= occupied_thresh <= 1"),
    ("image: m.pgm\nresolution: 1\norigin: [0, 0, 0]\nnegate: yes please\noccupied_thresh: 0.6\nfree_thresh: 0.2\n",
     "'negate' must be"),
    ("{REST}mode: fancy\n", "mode 'fancy'"),
    ("image: none.pgm\nresolution: 1\norigin: [0, 0, 0]\nnegate: 0\noccupied_thresh: 0.6\nfree_thresh: 0.2\n",
     "none.pgm: no such file"),
    ("image: ''\nresolution: 1\norigin: [0, 0, 0]\nnegate: 0\noccupied_thresh: 0.6\nfree_thresh: 0.2\n",
     "'image' must name"),
    ("image: junk.pgm\nresolution: 1\norigin: [0, 0, 0]\nnegate: 0\noccupied_thresh: 0.6\nfree_thresh: 0.2\n",
     "not a readable image"),
])
def test_bad_yaml_is_one_clear_error(tmp_path, text, message):
    pgm(tmp_path / "m.pgm", [[0, 254]])
    (tmp_path / "junk.pgm").write_bytes(b"P5\n99 99\n255\nshort")
    rest = "image: m.pgm\nresolution: 1\nnegate: 0\noccupied_thresh: 0.6\nfree_thresh: 0.2\n"
    (tmp_path / "bad.yaml").write_text(text.replace("{REST}", rest if "origin" in text else
                                                    rest + "origin: [0, 0, 0]\n"))
    with pytest.raises(MapFormatError, match=message) as info:
        load(tmp_path / "bad.yaml")
    assert "\n" not in str(info.value)
