"""Static images for CI artefacts (``ndbg analyze --png DIR`` / ``--svg DIR``): the plan's
exploded-view strip (``plan``), the sphere map of each family (``sphere-FAMILY``) and the
plan's tree (``tree``), drawn headless with matplotlib's Agg backend (no display, no GPU).

Byte-identical from run to run: fixed sizes and DPI, no creation date or software version in
the files' metadata, a fixed SVG hash salt; the SVGs' text is drawn as paths, so they do not
depend on the viewer's fonts.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..core.assembly import Assembly
from ..core.files import write_atomic
from ._scene import DisplayMesh, Move, disassembly, display_meshes, distinct_colour, poses
from .sphere import SphereMap, dbg_grid, sphere_maps
from .tree import MOVED_EDGE, REST_EDGE, TreeLayout, tree_layout

#: Resolution of the PNGs (dots per inch; the figure sizes are in inches).
DPI = 100

#: Panels of the plan's strip: the assembled pose, evenly spread steps, and the last one.
MAX_PANELS = 8

#: Triangles drawn per panel (matplotlib's 3D sorts every polygon in Python).
STRIP_TRIANGLES = 12_000

#: Columns of the plan's strip.
COLUMNS = 4


def _pyplot():
    """pyplot on the Agg backend, imported only when an image is asked for."""
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    return plt


def _panels(n: int) -> list[int]:
    """The poses shown: 0, evenly spread ones, and ``n`` (at most :data:`MAX_PANELS`)."""
    if n + 1 <= MAX_PANELS:
        return list(range(n + 1))
    return sorted({round(k * n / (MAX_PANELS - 1)) for k in range(MAX_PANELS)})


def plan_strip(meshes: list[DisplayMesh], moves: list[Move], offsets: np.ndarray):
    """The figure of the exploded poses, the moving parts of each shown step in colour."""
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    from ._scene import pale, pose_bounds

    plt = _pyplot()
    shown = _panels(len(moves))
    rows = (len(shown) + COLUMNS - 1) // COLUMNS
    fig = plt.figure(figsize=(4 * min(COLUMNS, len(shown)), 4 * rows), dpi=DPI)
    lo, hi = pose_bounds(meshes, offsets)
    for n, j in enumerate(shown):
        ax = fig.add_subplot(rows, min(COLUMNS, len(shown)), n + 1, projection="3d")
        movers = set(moves[j - 1].parts) if j else None
        for k, m in enumerate(meshes):
            tris = (m.vertices + offsets[j, k])[m.faces]
            colour = m.colour if movers is None or m.id in movers else pale(m.colour)
            # rasterized: an SVG strip of vector triangles is megabytes
            ax.add_collection3d(Poly3DCollection(tris, facecolors=colour, linewidths=0,
                                                 rasterized=True,
                                                 shade=True))
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_zlim(lo[2], hi[2])
        ax.set_box_aspect(tuple(np.maximum(hi - lo, 1e-9)))
        ax.view_init(elev=22, azim=-50)
        ax.set_axis_off()
        title = "assembled" if j == 0 else f"step {j}/{len(moves)}: " + ", ".join(
            moves[j - 1].parts)
        ax.set_title(title if len(title) < 48 else title[:45] + "...", fontsize=9)
    fig.subplots_adjust(left=0, right=1, bottom=0, top=0.95, wspace=0, hspace=0.08)
    return fig


def sphere_figure(report: dict, m: SphereMap):
    """The family's sphere as a longitude-latitude map: the sampled regions filled (region
    maps), the representatives as dots, the plan's directions as black diamonds."""
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch

    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(9, 5), dpi=DPI)
    drawn = m.distinct_drawn
    colours = [distinct_colour(k) for k in drawn]
    if m.mode == "regions" and len(m.faces):
        grid = dbg_grid(report, m)
        slot = np.full(max(drawn, default=0) + 2, len(drawn))  # -1 (none listed): last
        slot[drawn] = np.arange(len(drawn))
        idx = slot[grid]
        cmap = ListedColormap(colours + ["#bbbbbb"])
        ax.imshow(idx, cmap=cmap, vmin=-0.5, vmax=len(drawn) + 0.5, interpolation="nearest",
                  extent=(-180, 180, -90, 90), aspect="auto")
    else:
        ax.set_facecolor("#f2f2f2")

    def lonlat(d) -> tuple[float, float]:
        d = np.asarray(d, dtype=float)
        return (float(np.degrees(np.arctan2(d[1], d[0]))),
                float(np.degrees(np.arcsin(np.clip(d[2], -1, 1)))))

    for d, k, dim in m.representatives:
        x, y = lonlat(d)
        ax.scatter([x], [y], s=14 + 10 * (2 - min(dim, 2)), color=distinct_colour(k),
                   edgecolors="#222222", linewidths=0.5, zorder=3)
    for _step, d in m.plan:
        x, y = lonlat(d)
        ax.scatter([x], [y], marker="D", s=40, color="black", zorder=4)
    ax.set_xlim(-180, 180)
    ax.set_ylim(-90, 90)
    ax.set_xlabel("longitude (degrees, from +x towards +y)")
    ax.set_ylabel("latitude (degrees, +z up)")
    ax.set_title(f"{m.family.replace('_', ' ')}: {len(drawn)} distinct DBGs"
                 + ("" if m.mode == "regions" else " (representative directions only)"),
                 fontsize=10)
    handles = [Patch(color=c, label=f"DBG {k}") for k, c in zip(drawn[:24], colours)]
    if handles:
        ax.legend(handles=handles, fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1),
                  ncol=1 + len(handles) // 13)
    fig.tight_layout()
    return fig


def tree_figure(layout: TreeLayout, colours: dict[str, str]):
    """The plan's tree: steps as numbered circles, parts as coloured leaves."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(max(4, 0.45 * layout.leaves + 1), 1 + 0.7 * layout.levels),
                           dpi=DPI)
    nodes = layout.nodes
    for p, c, moved in layout.edges:
        a, b = nodes[p], nodes[c]
        ax.plot([a.x, b.x, b.x], [-a.y, -(a.y + 0.5), -b.y], color=MOVED_EDGE if moved
                else REST_EDGE, linewidth=2 if moved else 1.2, zorder=1)
    for n in nodes:
        if n.leaf:
            ax.scatter([n.x], [-n.y], s=60, color=colours.get(n.label, "#888888"),
                       edgecolors="#333333", zorder=2)
            ax.text(n.x, -n.y - 0.25, n.label, rotation=60, ha="right", va="top", fontsize=8,
                    rotation_mode="anchor")
        else:
            ax.scatter([n.x], [-n.y], s=260, color="white", edgecolors="#333333", zorder=2)
            ax.text(n.x, -n.y, n.label, ha="center", va="center", fontsize=8, zorder=3)
    ax.set_xlim(-0.8, layout.leaves - 0.2)
    ax.set_ylim(-(layout.levels - 1) - 2.6, 0.6)
    ax.set_axis_off()
    ax.set_title("assembly tree of the plan (red: the side inserted)", fontsize=10)
    fig.tight_layout()
    return fig


def _save(fig, path: Path, fmt: str) -> None:
    import io

    import matplotlib

    plt = _pyplot()
    out = io.BytesIO()
    with matplotlib.rc_context({"svg.hashsalt": "ndbg", "svg.fonttype": "path"}):
        meta = {"Date": None, "Creator": None} if fmt == "svg" else {"Software": None}
        fig.savefig(out, format=fmt, dpi=DPI, metadata=meta)
    plt.close(fig)
    write_atomic(path, out.getvalue())


def write_images(report: dict, asm: Assembly, folder: str | Path, fmt: str = "png"
                 ) -> list[Path]:
    """Write the plan's strip, each family's sphere map and the tree of ``report`` into
    ``folder`` (made if missing) as ``fmt`` (``png`` or ``svg``); the paths written."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    meshes = display_meshes(asm, max_triangles=STRIP_TRIANGLES)
    moves = disassembly(report, meshes)
    offsets = poses(meshes, moves)
    figures = [("plan", plan_strip(meshes, moves, offsets))]
    figures += [(f"sphere-{m.family}", sphere_figure(report, m)) for m in sphere_maps(report)]
    layout = tree_layout(report)
    if layout is not None:
        figures.append(("tree", tree_figure(layout, {m.id: m.colour for m in meshes})))
    written = []
    for name, fig in figures:
        path = folder / f"{name}.{fmt}"
        _save(fig, path, fmt)
        written.append(path)
    return written
