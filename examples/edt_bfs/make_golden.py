"""Regenerate the EDT/BFS example's stimulus and expected results from the golden model.

    python examples/edt_bfs/make_golden.py

Reads image.txt (``#`` obstacle), the job below and the array size from
edt_bfs_example.core; runs ``models.edt_bfs.plan_path`` and writes, packed as
the manifest edt_bfs_height8_width8.json describes the stream payloads:

* stimulus.hex: the command word, then the image columns in the order the
  core takes them (column width-1 first);
* expected.hex: every o_stream beat (the path from the start to the goal,
  then every cell in row-major order, the last one flagged);
* meta.hex: beats, EDT iterations, BFS iterations, job cycles.
"""

import sys
from pathlib import Path

import yaml

from navcores.hdl.edt_bfs.cell import cell_widths
from navcores.hdl.edt_bfs.edt_bfs import command_layout, image_layout, result_layout
from navcores.models.edt_bfs import plan_path
from navcores.models.maps import load_grid

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))   # examples/golden_files.py
from golden_files import run, write_or_check  # noqa: E402

MAX_BEATS = 128         # tb_edt_bfs.v's memory
GOAL, START, DFAR = (0, 7), (7, 0), 0


def pack(layout, **values):
    word = 0
    for name, v in values.items():
        f = layout[name]
        word |= (int(v) & ((1 << f.width) - 1)) << f.offset
    return word


def main(check=False):
    """Write the files (``check``: only compare them with the stored ones; True if equal)."""
    files = {}
    core = yaml.safe_load((HERE / "edt_bfs_example.core").read_text())
    p = core["generate"]["planner"]["parameters"]
    h, w = p["height"], p["width"]
    img = load_grid(HERE / "image.txt")
    assert img.shape == (h, w), (img.shape, h, w)
    wd = cell_widths(h, w)
    cmd, col, res = command_layout(wd), image_layout(h), result_layout(wd)
    m = plan_path(img, [GOAL], START, DFAR)
    assert m.path_found, "the example needs a path"

    stim = [pack(cmd, dfar=DFAR, start_row=START[0], start_col=START[1], path=1)]
    for c in reversed(range(w)):
        stim.append(pack(col, obst=sum(int(img[r, c]) << r for r in range(h)),
                         goal=sum(int((r, c) == GOAL) << r for r in range(h))))

    def cell(r, c, is_cell, last=False):
        done = bool(m.done[r, c])
        return pack(res, cell=is_cell, row=r, col=c, done=done,
                    di=m.distance[r, c] if done else 0,
                    dx=m.vector[r, c][0] if done else 0, dy=m.vector[r, c][1] if done else 0,
                    cfr=m.cfr[r, c], visited=m.visited[r, c], parent=m.parent[r, c], last=last)

    beats = [cell(r, c, 0) for r, c in m.path]
    beats += [cell(r, c, 1, last=(r, c) == (h - 1, w - 1)) for r in range(h) for c in range(w)]
    head = [f"// examples/edt_bfs: python examples/edt_bfs/make_golden.py (image.txt, goal {GOAL}, "
            f"start {START}, dfar {DFAR})"]
    files["stimulus.hex"] = ("\n".join(head + [f"{x:x}" for x in stim]) + "\n")
    assert len(beats) <= MAX_BEATS
    pad = ["// unused (tb_edt_bfs.v reads MAX_BEATS words)"] + ["0"] * (MAX_BEATS - len(beats))
    files["expected.hex"] = ("\n".join(head + [f"{x:x}" for x in beats] + pad) + "\n")
    meta = [len(beats), m.iterations_edt, m.iterations_bfs, m.cycles]
    files["meta.hex"] = ("\n".join(head + ["// beats, EDT iterations, BFS iterations, cycles"]
                                             + [f"{x:x}" for x in meta]) + "\n")
    print(f"path of {len(m.path)} pixels {m.path}; {len(beats)} beats; "
          f"{m.iterations_edt} EDT + {m.iterations_bfs} BFS iterations, {m.cycles} cycles")
    print(f"payload widths: command {cmd.size}, column {col.size}, result {res.size}")
    return write_or_check(HERE, files, check)


if __name__ == "__main__":
    run(main)
