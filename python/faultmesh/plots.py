"""Pictures (matplotlib, Agg backend: no screen needed).

* :func:`plot_model_3d` — the model in 3D: layers coloured by layer (legend),
  faults in a contrasting dark red, shaded, vertically exaggerated.
* :func:`plot_section` — one cross-section (the paper's Figure 7): s across,
  elevation up, the units between layer tops filled with the layer colours,
  faults as dark lines.
* :func:`plot_gap` / :func:`plot_gaps` — stitched gaps close up in plan view:
  layer triangles grey, gap triangles coloured by their smallest angle, the
  fault patch hatched and outlined.
* :func:`plot_map` — plan view: the study area, fault footprints, section lines.

Colours are the same in every picture (:func:`layer_color`).
"""
from __future__ import annotations

from pathlib import Path
from typing import Iterable, Optional, Sequence

import numpy as np

# Earth-tone palette, top to bottom (the paper's Figure 5 uses green topsoil,
# yellow clay and dark coal; dark red is kept for faults so they stand out).
_PALETTE = ["#6aa84f", "#e6c04a", "#7f6a55", "#4f6d8f", "#b0705a", "#7fb7a8",
            "#c9a26b", "#8e7cc3", "#a7a7a7", "#4d6b4d"]
FAULT_COLOR = "#8b1a1a"
GAP_CMAP = "RdYlGn"


def layer_color(order: int, n_layers: int = 0) -> str:
    """Colour of the layer at position ``order`` (0 = top) in every picture."""
    return _PALETTE[int(order) % len(_PALETTE)]


def _plt():
    import matplotlib

    if matplotlib.get_backend().lower() not in ("agg", "pdf", "svg", "ps", "cairo"):
        try:
            matplotlib.use("Agg", force=True)
        except Exception:  # pragma: no cover (backend switching refused)
            pass
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path) -> None:
    if path is None:
        return
    from .formats._common import AtomicFiles

    path = Path(path)
    fmt = path.suffix.lstrip(".").lower() or "png"
    with AtomicFiles() as files:
        tmp = files.temp_path(path)
        fig.savefig(tmp, dpi=150, format=fmt, bbox_inches="tight")


def _nice(v: float) -> float:
    """Round ``v`` > 0 to 1, 2, 2.5 or 5 times a power of ten (for exaggerations)."""
    if v <= 1:
        return 1.0
    e = 10 ** np.floor(np.log10(v))
    for m in (1, 2, 2.5, 5, 10):
        if v <= m * e * 1.2:
            return float(m * e)
    return float(10 * e)


def _auto_exaggeration(width: float, zrange: float, target: float) -> float:
    if zrange <= 0 or width <= 0:
        return 1.0
    return _nice(target * width / zrange)


# ----------------------------------------------------------------------------
# 3D view
# ----------------------------------------------------------------------------

def _shaded(P: np.ndarray, T: np.ndarray, color, alpha: float, light: np.ndarray) -> np.ndarray:
    from matplotlib.colors import to_rgb

    tri = P[T]
    nrm = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    ln = np.linalg.norm(nrm, axis=1)
    ln[ln == 0] = 1
    nrm /= ln[:, None]
    nrm[nrm[:, 2] < 0] *= -1     # two-sided lighting (strip triangles face down)
    shade = 0.5 + 0.5 * np.clip(nrm @ light, 0, 1)
    base = np.array(to_rgb(color))
    return np.column_stack([np.clip(base[None, :] * shade[:, None], 0, 1),
                            np.full(len(shade), alpha)])


def _outline(ax, surf, ve: float, color, z) -> None:
    """The surface's boundary edges as a darker line (its level at the sides)."""
    from matplotlib.colors import to_rgb
    from mpl_toolkits.mplot3d.art3d import Line3DCollection

    T = surf.triangles
    if len(T) == 0:
        return
    e = np.sort(np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]]), axis=1)
    u, cnt = np.unique(e, axis=0, return_counts=True)
    seg = surf.vertices[u[cnt == 1]].copy()
    seg[:, :, 2] *= ve
    ax.add_collection3d(Line3DCollection(seg, colors=[np.array(to_rgb(color)) * 0.6],
                                         linewidths=1.6, zorder=z))


def _frame_3d(fig, ax, lo, hi, zbot, ve, elev, azim):
    """Limits, aspect, view and labelled ticks of a 3D panel whose z axis is
    exaggerated by ``ve``: tick labels show true elevations."""
    from matplotlib.ticker import FuncFormatter, MaxNLocator

    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(zbot * ve, hi[2] * ve)
    ax.set_box_aspect((hi[0] - lo[0], hi[1] - lo[1], max((hi[2] - zbot) * ve, 1e-9)))
    fig.subplots_adjust(left=0.0, right=0.97, bottom=0.02, top=0.95)
    ax.view_init(elev=elev, azim=azim)
    for axis in (ax.xaxis, ax.yaxis):
        axis.set_major_locator(MaxNLocator(5))
        axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:.0f}"))
    ax.zaxis.set_major_locator(MaxNLocator(5))
    ax.zaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v / ve:.0f}"))
    ax.set_xlabel("x (m)", labelpad=10)
    ax.set_ylabel("y (m)", labelpad=10)
    ax.set_zlabel("elevation (m)", labelpad=6)
    ax.tick_params(labelsize=7)


def plot_model_3d(model, path=None, *, vertical_exaggeration: Optional[float] = None,
                  elev: float = 30.0, azim: float = -60.0, title: Optional[str] = None,
                  show_faults: bool = True, upper_alpha: float = 0.55, figsize=(11, 8.5)):
    """The model in 3D, seen from above.

    Layer surfaces never cross, and a camera looking down meets an upper
    surface before a lower one, so drawing the layers from the bottom up is
    an exact occlusion order between layers (matplotlib's per-polygon depth
    sort is not: big triangles of a lower layer bleed through). The upper
    layers are drawn translucent (``upper_alpha``) so the deeper seams and the
    faults show through; the bottom layer is opaque. Faces are shaded by a
    light from the north-west, after exaggerating z (``vertical_exaggeration``,
    automatic by default). Returns the figure."""
    plt = _plt()
    from matplotlib.patches import Patch
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    layers = list(model.surfaces.values())
    faults = list(model.faults.values()) if show_faults else []
    allv = [s.vertices for s in layers + faults if s.n_vertices]
    if not allv:
        raise ValueError("plot_model_3d: the model has no vertices")
    allv = np.vstack(allv)
    lo, hi = allv.min(0), allv.max(0)
    width = float(max(hi[0] - lo[0], hi[1] - lo[1]))
    ve = vertical_exaggeration or _auto_exaggeration(width, float(hi[2] - lo[2]), 0.3)
    light = np.array([-0.5, 0.6, 1.0])
    light /= np.linalg.norm(light)

    fig = plt.figure(figsize=figsize)
    ax = fig.add_subplot(projection="3d")
    ax.computed_zorder = False   # draw in the order added (bottom up), see above

    def add(surf, color, alpha, z, edge=None):
        if surf.n_triangles == 0:
            return
        P = surf.vertices.copy()
        P[:, 2] *= ve
        fc = _shaded(P, surf.triangles, color, alpha, light)
        coll = Poly3DCollection(P[surf.triangles], facecolors=fc,
                                edgecolors=edge if edge is not None else "none",
                                linewidths=0.3 if edge is not None else 0, zorder=z)
        ax.add_collection3d(coll)

    n = len(layers)
    z = 0
    for k in range(n - 1, -1, -1):
        # Opaque at the bottom, more transparent upwards: every seam stays readable.
        alpha = 1.0 if k == n - 1 else upper_alpha * (0.45 + 0.85 * k / max(n - 2, 1))
        add(layers[k], layer_color(k), alpha, z)
        z += 1
        _outline(ax, layers[k], ve, layer_color(k), z)
        z += 1
        if k == n - 1:
            for f in faults:     # just above the deepest layer: seen through the others
                add(f, FAULT_COLOR, 0.95, z, edge=(0.35, 0.05, 0.05, 0.6))
                z += 1
    _frame_3d(fig, ax, lo, hi, lo[2], ve, elev, azim)
    handles = [Patch(facecolor=layer_color(i), edgecolor="0.3", label=name)
               for i, name in enumerate(model.surfaces)]
    if faults:
        handles.append(Patch(facecolor=FAULT_COLOR, edgecolor="0.3",
                             label="fault planes: " + ", ".join(model.faults)))
    ax.legend(handles=handles, loc="upper left", fontsize=9, frameon=True, title="layer tops",
              title_fontsize=9)
    ax.set_title(title or f"{model.name}: {n} layers, {len(model.faults)} faults "
                 f"(vertical exaggeration ×{ve:g}, upper layers translucent)", fontsize=11)
    _save(fig, path)
    return fig


GAP_COLOR = "#e4572e"


def plot_layers_3d(model, path=None, *, vertical_exaggeration: Optional[float] = None,
                   elev: float = 35.0, azim: float = -60.0, ncols: int = 2):
    """One opaque 3D panel per layer (small multiples), each with its own
    exaggeration so the faults' steps show: stitched gap triangles in orange,
    fault patches in dark red. Returns the figure."""
    plt = _plt()
    from matplotlib.patches import Patch
    from matplotlib.ticker import FuncFormatter, MaxNLocator
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    names = list(model.surfaces)
    if not names:
        raise ValueError("plot_layers_3d: the model has no layers")
    ncols = min(ncols, len(names))
    nrows = int(np.ceil(len(names) / ncols))
    fig = plt.figure(figsize=(6.2 * ncols, 5.0 * nrows + 0.6))
    light = np.array([-0.5, 0.6, 1.0])
    light /= np.linalg.norm(light)
    for k, name in enumerate(names):
        s = model.surfaces[name]
        ax = fig.add_subplot(nrows, ncols, k + 1, projection="3d")
        if s.n_triangles == 0:
            ax.set_title(f"{name}: empty")
            continue
        V = s.vertices
        lo, hi = V.min(0), V.max(0)
        width = float(max(hi[0] - lo[0], hi[1] - lo[1]))
        # Capped: a nearly flat layer would otherwise get x100 and look rugged.
        ve = vertical_exaggeration or min(20.0, _auto_exaggeration(width, float(hi[2] - lo[2]), 0.2))
        P = V.copy()
        P[:, 2] *= ve
        fc = _shaded(P, s.triangles, layer_color(k), 1.0, light)
        gaps = [g for g in model.gaps if g.layer == name]
        for g in gaps:
            rows = np.asarray(g.triangles, dtype=np.int64).reshape(-1)
            fc[rows] = _shaded(P, s.triangles[rows], GAP_COLOR, 1.0, light)
            patch = patch_triangles(model, g)
            if len(patch):
                fc[patch] = _shaded(P, s.triangles[patch], FAULT_COLOR, 1.0, light)
        ax.add_collection3d(Poly3DCollection(P[s.triangles], facecolors=fc, edgecolors="none",
                                             linewidths=0))
        _outline(ax, s, ve, layer_color(k), 1)
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_zlim(lo[2] * ve, hi[2] * ve)
        ax.set_box_aspect((hi[0] - lo[0], hi[1] - lo[1], max((hi[2] - lo[2]) * ve, 1e-9)), zoom=1.15)
        ax.view_init(elev=elev, azim=azim)
        for axis in (ax.xaxis, ax.yaxis):
            axis.set_major_locator(MaxNLocator(4))
            axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:.0f}"))
        ax.zaxis.set_major_locator(MaxNLocator(3))
        ax.zaxis.set_major_formatter(FuncFormatter(lambda v, _, ve=ve: f"{v / ve:.0f}"))
        ax.tick_params(labelsize=6)
        ax.set_zlabel("elevation (m)", fontsize=7, labelpad=2)
        ax.set_title(f"{name}: {s.n_triangles} triangles, {len(gaps)} stitched gap(s)\n"
                     f"z {lo[2]:.0f} … {hi[2]:.0f} m, vertical exaggeration ×{ve:g}", fontsize=9)
    handles = [Patch(facecolor=GAP_COLOR, label="stitched gap triangles"),
               Patch(facecolor=FAULT_COLOR, label="fault patch (fine fault model)")]
    fig.legend(handles=handles, loc="lower center", ncol=2, fontsize=9, frameon=False)
    fig.suptitle(f"{model.name}: layer surfaces", fontsize=12)
    fig.subplots_adjust(left=0.02, right=0.98, bottom=0.06, top=0.92, wspace=0.05, hspace=0.12)
    _save(fig, path)
    return fig


def _envelope(section, name: str, s: np.ndarray) -> np.ndarray:
    """Upper envelope z(s) of a surface's section polylines (NaN where none).
    A reverse fault's fold is reduced to its upper sheet: good enough for a
    fence picture, and what a vertical borehole would meet first."""
    z = np.full(len(s), np.nan)
    for ln in section.polylines(name):
        ss, zz = ln.s, ln.xyz[:, 2]
        for k in range(len(ss) - 1):
            a, b = ss[k], ss[k + 1]
            lo, hi = min(a, b), max(a, b)
            m = (s >= lo) & (s <= hi)
            if not m.any():
                continue
            zi = np.full(m.sum(), max(zz[k], zz[k + 1])) if hi == lo else \
                zz[k] + (s[m] - a) / (b - a) * (zz[k + 1] - zz[k])
            z[m] = np.fmax(z[m], zi)
    return z


def plot_fence_3d(model, sections, path=None, *, vertical_exaggeration: Optional[float] = None,
                  elev: float = 28.0, azim: float = -60.0, samples: int = 160,
                  first_layer: int = 0, title: Optional[str] = None):
    """Fence diagram: the given cross-sections (:class:`~faultmesh.section.CrossSection`)
    stood up in 3D, the unit below each layer top filled with the layer's
    colour, faults as dark red lines on the panels and translucent planes,
    the deepest layer as the floor and the study area outlined at the top.
    Each panel is cut into narrow vertical quads so that matplotlib's
    painter's sort orders panels and faults correctly. ``first_layer`` > 0
    starts the panels at that layer's top (e.g. 1 leaves out a thick, plain
    topsoil unit so the faulted seams get the height). Returns the figure."""
    plt = _plt()
    from matplotlib.colors import to_rgb
    from matplotlib.patches import Patch
    from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection

    sections = [sec for sec in sections if sec.lines]
    all_layers = list(model.surfaces)
    if not 0 <= first_layer < len(all_layers):
        raise ValueError(f"plot_fence_3d: first_layer must be in 0..{len(all_layers) - 1}, "
                         f"got {first_layer}")
    layers = all_layers[first_layer:]
    allv = np.vstack([model.surfaces[n].vertices for n in layers if model.surfaces[n].n_vertices])
    lo, hi = allv.min(0), allv.max(0)
    width = float(max(hi[0] - lo[0], hi[1] - lo[1]))
    zbot = lo[2] - 0.05 * (hi[2] - lo[2])
    ve = vertical_exaggeration or _auto_exaggeration(width, float(hi[2] - zbot), 0.3)
    light = np.array([-0.5, 0.6, 1.0])
    light /= np.linalg.norm(light)
    fig = plt.figure(figsize=(11, 8.5))
    ax = fig.add_subplot(projection="3d")
    ax.computed_zorder = False
    # Floor: the deepest layer, drawn first (everything else is above it).
    floor = model.surfaces[layers[-1]] if layers else None
    if floor is not None and floor.n_triangles:
        P = floor.vertices.copy()
        P[:, 2] *= ve
        ax.add_collection3d(Poly3DCollection(P[floor.triangles], facecolors=_shaded(
            P, floor.triangles, layer_color(len(all_layers) - 1), 0.55, light), edgecolors="none",
            zorder=0))
    # Camera direction in XY (mplot3d: azim measured from +x towards +y): each
    # object (a section panel with its lines, a fault plane) is drawn as its
    # own collection, farthest first - panels are planar, so this painter's
    # order is right except where a fault plane passes through a panel.
    cam = np.array([np.cos(np.radians(azim)), np.sin(np.radians(azim))])
    objects = []   # (depth, kind, payload)
    for sec in sections:
        smin = min(float(ln.s.min()) for ln in sec.lines)
        smax = max(float(ln.s.max()) for ln in sec.lines)
        sg = np.linspace(smin, smax, samples)
        zs = [_envelope(sec, n, sg) for n in layers] + [np.full(len(sg), zbot)]
        d = sec.direction
        xy = sec.origin[None, :] + sg[:, None] * d[None, :]
        # A panel facing the light is brighter: the same shading as the surfaces.
        nrm = np.array([d[1], -d[0], 0.0])
        shade = 0.62 + 0.38 * abs(float(nrm @ light))
        polys, colors = [], []
        for i, n in enumerate(layers):
            top, below = zs[i], zs[i + 1]
            # The unit ends at the next layer down that exists here.
            for j in range(i + 2, len(zs)):
                below = np.where(np.isnan(below), zs[j], below)
            ok = ~np.isnan(top[:-1]) & ~np.isnan(top[1:]) & ~np.isnan(below[:-1]) & ~np.isnan(below[1:])
            col = tuple(np.clip(np.array(to_rgb(layer_color(i + first_layer))) * shade, 0, 1)) + (1.0,)
            k = np.flatnonzero(ok)
            q = np.stack([np.column_stack([xy[k], top[k] * ve]),
                          np.column_stack([xy[k + 1], top[k + 1] * ve]),
                          np.column_stack([xy[k + 1], below[k + 1] * ve]),
                          np.column_stack([xy[k], below[k] * ve])], axis=1)
            polys.extend(q)
            colors.extend([col] * len(k))
        segs, scol, widths = [], [], []
        for ln in sec.lines:
            if ln.kind != "fault" and ln.surface not in layers:
                continue
            P = ln.xyz.copy()
            keep = np.ones(len(P) - 1, dtype=bool)
            if ln.kind == "fault" and first_layer:
                # Only the part of a fault below the first panel's top.
                env = _envelope(sec, layers[0], ln.s)
                below_top = ~(P[:, 2] > env + 1e-9)
                keep = below_top[:-1] & below_top[1:]
            P[:, 2] *= ve
            seg = np.stack([P[:-1], P[1:]], axis=1)[keep]
            segs.extend(seg)
            if ln.kind == "fault":
                c, w = FAULT_COLOR, 2.4
            else:
                c, w = tuple(np.array(to_rgb(layer_color(all_layers.index(ln.surface)))) * 0.55), 1.0
            scol.extend([c] * len(seg))
            widths.extend([w] * len(seg))
        depth = float(xy.mean(0) @ cam)
        objects.append((depth, "panel", (polys, colors, segs, scol, widths)))
    for f in model.faults.values():
        if f.n_triangles == 0:
            continue
        P = f.vertices.copy()
        P[:, 2] *= ve
        objects.append((float(f.vertices[:, :2].mean(0) @ cam), "fault",
                        (P[f.triangles], _shaded(P, f.triangles, FAULT_COLOR, 0.5, light))))
    if model.boundary is not None:
        b0 = np.asarray(model.boundary, dtype=np.float64)
        ring = np.vstack([b0, b0[:1]])
        ax.plot(ring[:, 0], ring[:, 1], np.full(len(ring), zbot * ve), color="0.3", lw=0.9,
                ls=":", zorder=1)
    z = 2
    for _, kind, payload in sorted(objects, key=lambda o: o[0]):
        if kind == "panel":
            polys, colors, segs, scol, widths = payload
            if polys:
                # Edges in the face colour hide the hairline seams between quads.
                ax.add_collection3d(Poly3DCollection(polys, facecolors=colors, edgecolors=colors,
                                                     linewidths=0.4, zorder=z))
            if segs:
                ax.add_collection3d(Line3DCollection(segs, colors=scol, linewidths=widths,
                                                     zorder=z + 1))
        else:
            tris, fc = payload
            ax.add_collection3d(Poly3DCollection(tris, facecolors=fc, edgecolors="none", zorder=z))
        z += 2
    if model.boundary is not None and layers:
        # The study area at the top of the model, drawn last (thin, above all).
        top = model.surfaces[layers[0]]
        zt = float(np.nanmax(top.vertices[:, 2])) if top.n_vertices else hi[2]
        ax.plot(ring[:, 0], ring[:, 1], np.full(len(ring), zt * ve), color="0.3", lw=0.9,
                zorder=z)
    for sec in sections:
        smax = max(float(ln.s.max()) for ln in sec.lines)
        p = sec.origin + smax * sec.direction
        ax.text(p[0], p[1], hi[2] * ve, f" {sec.name}", fontsize=9, fontweight="bold", zorder=4)
    _frame_3d(fig, ax, lo, hi, zbot, ve, elev, azim)
    handles = [Patch(facecolor=layer_color(i + first_layer), edgecolor="0.3", label=n)
               for i, n in enumerate(layers)]
    handles.append(Patch(facecolor=FAULT_COLOR, edgecolor="0.3", alpha=0.7, label="faults"))
    ax.legend(handles=handles, loc="upper left", fontsize=9, title="units (below each top)",
              title_fontsize=9)
    above = f" below the top of {layers[0]}" if first_layer else ""
    ax.set_title(title or f"{model.name}: fence diagram, {len(sections)} sections{above}, "
                 f"vertical exaggeration ×{ve:g}", fontsize=11)
    _save(fig, path)
    return fig


# ----------------------------------------------------------------------------
# Sections
# ----------------------------------------------------------------------------

def _compass(az: float) -> str:
    names = ["N", "NE", "E", "SE", "S", "SW", "W", "NW"]
    return names[int(((az % 360) + 22.5) // 45) % 8]


def plot_section(section, path=None, *, vertical_exaggeration: Optional[float] = None,
                 title: Optional[str] = None, ax=None, fill: bool = True, figsize=(12, 5)):
    """Draw a :class:`faultmesh.section.CrossSection`.

    With ``fill`` the unit below each layer top is filled with the layer's
    colour down to the bottom of the picture, top layer first, so each band
    between two layer tops shows the colour of the upper one (a polygon per
    polyline; the nonzero fill rule also fills the overlap of a reverse fault
    correctly). Layer tops are thin darker lines, faults thick dark red.
    """
    plt = _plt()
    from matplotlib.colors import to_rgb
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch, Polygon

    lines = section.lines
    own = ax is None
    if own:
        fig, ax = plt.subplots(figsize=figsize)
    else:
        fig = ax.figure
    if not lines:
        ax.text(0.5, 0.5, "the section plane misses the model", ha="center", va="center",
                transform=ax.transAxes)
        _save(fig, path)
        return fig
    s_all = np.concatenate([ln.s for ln in lines])
    z_all = np.concatenate([ln.xyz[:, 2] for ln in lines])
    smin, smax = float(s_all.min()), float(s_all.max())
    zmin, zmax = float(z_all.min()), float(z_all.max())
    zr = max(zmax - zmin, 1e-9)
    bottom = zmin - 0.08 * zr
    top = zmax + 0.06 * zr
    ve = vertical_exaggeration or _auto_exaggeration(smax - smin, top - bottom, 0.3)
    order = {name: i for i, name in enumerate(section.layers)}
    if fill:
        for name in section.layers:
            col = np.array(to_rgb(layer_color(order[name])))
            light = 1 - 0.45 * (1 - col)             # pastel: lines stay readable on it
            for ln in section.polylines(name):
                if len(ln.s) < 2:
                    continue
                verts = np.vstack([np.column_stack([ln.s, ln.xyz[:, 2]]),
                                   [[ln.s[-1], bottom], [ln.s[0], bottom]]])
                ax.add_patch(Polygon(verts, closed=True, facecolor=light, edgecolor="none",
                                     zorder=1 + order[name]))
    for name in section.layers:
        col = np.array(to_rgb(layer_color(order[name])))
        for ln in section.polylines(name):
            ax.plot(ln.s, ln.xyz[:, 2], color=col * 0.75, lw=1.4, zorder=20)
    for name in section.faults:
        for ln in section.polylines(name):
            ax.plot(ln.s, ln.xyz[:, 2], color=FAULT_COLOR, lw=2.4, zorder=30,
                    solid_capstyle="round")
        pl = section.polylines(name)
        if pl:
            k = max(pl, key=lambda ln: len(ln.s))
            top_pt = int(np.argmax(k.xyz[:, 2]))
            ax.annotate(name, (k.s[top_pt], k.xyz[top_pt, 2]), xytext=(0, 6),
                        textcoords="offset points", ha="center", fontsize=9, color=FAULT_COLOR,
                        fontweight="bold", zorder=40)
    ax.set_xlim(smin, smax)
    ax.set_ylim(bottom, top)
    ax.set_aspect(ve)
    ax.set_xlabel(f"distance along the section from the origin (m), azimuth {section.azimuth:g}°")
    ax.set_ylabel("elevation (m)")
    ax.grid(True, color="0.85", lw=0.5, zorder=0)
    ax.text(0.0, 1.01, _compass(section.azimuth + 180), transform=ax.transAxes, ha="left",
            va="bottom", fontsize=10, fontweight="bold")
    ax.text(1.0, 1.01, _compass(section.azimuth), transform=ax.transAxes, ha="right",
            va="bottom", fontsize=10, fontweight="bold")
    handles = [Patch(facecolor=1 - 0.45 * (1 - np.array(to_rgb(layer_color(order[n])))),
                     edgecolor=np.array(to_rgb(layer_color(order[n]))) * 0.75, label=n)
               for n in section.layers if section.polylines(n)]
    if any(section.polylines(n) for n in section.faults):
        handles.append(Line2D([], [], color=FAULT_COLOR, lw=2.4, label="fault"))
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=9,
              frameon=False, title="units (below each top)", title_fontsize=9)
    o = section.origin
    name = f" {section.name}" if section.name else ""
    ax.set_title(title or f"Section{name} through ({o[0]:.0f}, {o[1]:.0f}), azimuth "
                 f"{section.azimuth:g}° — vertical exaggeration ×{ve:g}", fontsize=11, pad=16)
    if own:
        fig.tight_layout()
    _save(fig, path)
    return fig


# ----------------------------------------------------------------------------
# Gaps
# ----------------------------------------------------------------------------

def _plain_ticks(ax, n: int = 5) -> None:
    """Whole-metre tick labels without matplotlib's '1e6' offset (map coordinates)."""
    from matplotlib.ticker import FuncFormatter, MaxNLocator

    for axis in (ax.xaxis, ax.yaxis):
        axis.set_major_locator(MaxNLocator(n))
        axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:.0f}"))


def _neighbours(T: np.ndarray) -> np.ndarray:
    """(m, 3) triangle across edge k (vertices k, k+1), -1 on the boundary
    (and for edges shared by more than two triangles)."""
    m = len(T)
    e = np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]])
    key = np.sort(e, axis=1)
    owner = np.concatenate([np.arange(m)] * 3)
    slot = np.repeat([0, 1, 2], m)
    order = np.lexsort((key[:, 1], key[:, 0]))
    ks = key[order]
    same = np.all(ks[1:] == ks[:-1], axis=1)
    nb = np.full((m, 3), -1, dtype=np.int64)
    i = np.flatnonzero(same)
    # exactly two owners: not same with the previous pair and the next
    ok = np.ones(len(i), dtype=bool)
    ok &= ~np.isin(i - 1, i) & ~np.isin(i + 1, i)
    i = i[ok]
    a, b = order[i], order[i + 1]
    nb[owner[a], slot[a]] = owner[b]
    nb[owner[b], slot[b]] = owner[a]
    return nb


def patch_triangles(model, gap) -> np.ndarray:
    """Rows of the layer surface that form the fault patch(es) of ``gap``.

    A stitched layer knows each triangle's kind and owner
    (``Surface.kinds``/``Surface.owner``, set by :func:`faultmesh.build_model`
    and kept by ``.3dt`` files): the patch triangles owned by the gap's
    patches (``gap.patches``). A surface without them (read from a format
    that does not keep them) falls back to a guess: the triangles reachable
    from the gap without crossing it whose XY extent stays inside the gap's
    bounding box (the patch sits in the hole that the gap fills; the rest of
    the TIN reaches beyond it)."""
    from ._core import TriangleKind

    surf = model.surfaces[gap.layer]
    if surf.kinds is not None and surf.owner is not None:
        own = np.isin(surf.owner, np.asarray(getattr(gap, "patches", []), dtype=np.int64))
        return np.flatnonzero((surf.kinds == TriangleKind.patch) & own)
    return _patch_triangles_guess(surf, gap)


def _patch_triangles_guess(surf, gap) -> np.ndarray:
    """patch_triangles for a surface without kinds and owners (see there)."""
    T = surf.triangles
    rows = np.asarray(gap.triangles, dtype=np.int64).reshape(-1)
    if len(rows) == 0:
        return np.zeros(0, np.int64)
    V = surf.vertices
    gv = V[T[rows]].reshape(-1, 3)
    lo, hi = gv[:, :2].min(0), gv[:, :2].max(0)
    tol = 1e-9 * max(1.0, float(np.abs(np.concatenate([lo, hi])).max()))
    lo, hi = lo - tol, hi + tol
    nb = _neighbours(T)
    in_gap = np.zeros(len(T), dtype=bool)
    in_gap[rows] = True
    tl = V[T][:, :, :2]
    inside_box = np.all((tl >= lo) & (tl <= hi), axis=(1, 2))
    seeds = np.unique(nb[rows].ravel())
    seeds = seeds[(seeds >= 0) & ~in_gap[seeds]]
    # 0 unknown, 1 patch, 2 outside (escapes the box), 3 being visited
    state = np.zeros(len(T), dtype=np.int8)
    for sd in seeds.tolist():
        if state[sd]:
            continue
        comp, stack, escaped = [sd], [sd], False
        state[sd] = 3
        while stack:
            t = stack.pop()
            if not inside_box[t]:
                escaped = True
                break
            for u in nb[t].tolist():
                if u < 0 or in_gap[u]:
                    continue
                if state[u] == 2:      # joins a component already known to be outside
                    escaped = True
                    break
                if state[u] == 0:
                    state[u] = 3
                    comp.append(u)
                    stack.append(u)
            if escaped:
                break
        state[np.array(comp)] = 2 if escaped else 1
    return np.flatnonzero(state == 1)


def plot_gap(model, gap, ax=None, path=None, *, margin: float = 0.35, colorbar: bool = True):
    """One stitched gap in plan view (see the module docstring)."""
    plt = _plt()
    from matplotlib.collections import PolyCollection
    from matplotlib import colormaps
    from matplotlib.colors import Normalize

    from .report import min_angles

    surf = model.surfaces[gap.layer]
    V, T = surf.vertices, surf.triangles
    rows = np.asarray(gap.triangles, dtype=np.int64).reshape(-1)
    own = ax is None
    if own:
        fig, ax = plt.subplots(figsize=(6.5, 6))
    else:
        fig = ax.figure
    if len(rows) == 0:
        ax.text(0.5, 0.5, "empty gap", ha="center", va="center", transform=ax.transAxes)
        _save(fig, path)
        return fig
    patch = patch_triangles(model, gap)
    pts = V[T[np.concatenate([rows, patch])]].reshape(-1, 3)
    lo, hi = pts[:, :2].min(0), pts[:, :2].max(0)
    size = max(float((hi - lo).max()), 1e-9)
    pad = margin * size
    c = (lo + hi) / 2
    half = size / 2 + pad
    x0, x1, y0, y1 = c[0] - half, c[0] + half, c[1] - half, c[1] + half
    tri_xy = V[T][:, :, :2]
    vis = np.any((tri_xy[:, :, 0] >= x0) & (tri_xy[:, :, 0] <= x1) &
                 (tri_xy[:, :, 1] >= y0) & (tri_xy[:, :, 1] <= y1), axis=1)
    other = np.flatnonzero(vis)
    other = other[~np.isin(other, rows) & ~np.isin(other, patch)]
    ax.add_collection(PolyCollection(tri_xy[other], facecolors="0.93", edgecolors="0.6",
                                     linewidths=0.4, zorder=1))
    if len(patch):
        ax.add_collection(PolyCollection(tri_xy[patch], facecolors="none", edgecolors=FAULT_COLOR,
                                         linewidths=0.6, hatch="////", zorder=2, alpha=0.9))
        # Outline of the patch: its boundary edges.
        PT = T[patch]
        e = np.sort(np.concatenate([PT[:, [0, 1]], PT[:, [1, 2]], PT[:, [2, 0]]]), axis=1)
        u, cnt = np.unique(e, axis=0, return_counts=True)
        seg = V[u[cnt == 1]][:, :, :2]
        from matplotlib.collections import LineCollection

        ax.add_collection(LineCollection(seg, colors=FAULT_COLOR, linewidths=1.8, zorder=4))
    mins = min_angles(V, T[rows])
    norm = Normalize(0, 60)
    cmap = colormaps[GAP_CMAP]
    coll = PolyCollection(tri_xy[rows], facecolors=cmap(norm(mins)), edgecolors="0.15",
                          linewidths=0.8, zorder=3)
    ax.add_collection(coll)
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal")
    _plain_ticks(ax, 4)
    ax.tick_params(labelsize=7)
    n = len(rows)
    lt10 = np.count_nonzero(mins < 10) / n
    lt20 = np.count_nonzero(mins < 20) / n
    ax.set_title(f"{gap.fault} × {gap.layer}: {n} gap triangles\n"
                 f"min angle < 10°: {100 * lt10:.0f} %, < 20°: {100 * lt20:.0f} %", fontsize=9)
    if colorbar:
        from matplotlib.cm import ScalarMappable

        sm = ScalarMappable(norm=norm, cmap=cmap)
        cb = fig.colorbar(sm, ax=ax, shrink=0.8, pad=0.02)
        cb.set_label("smallest angle of a gap triangle (3D, degrees)", fontsize=8)
        cb.ax.tick_params(labelsize=7)
    _save(fig, path)
    return fig


def plot_gaps(model, path=None, *, gaps: Optional[Sequence] = None, ncols: int = 3):
    """Every stitched gap close up, one panel each, with a shared legend."""
    plt = _plt()
    from matplotlib.patches import Patch
    from matplotlib.cm import ScalarMappable
    from matplotlib import colormaps
    from matplotlib.colors import Normalize

    gaps = list(model.gaps if gaps is None else gaps)
    if not gaps:
        fig, ax = plt.subplots(figsize=(5, 2))
        ax.text(0.5, 0.5, "no stitched gaps in this model", ha="center", va="center")
        ax.axis("off")
        _save(fig, path)
        return fig
    ncols = min(ncols, len(gaps))
    nrows = int(np.ceil(len(gaps) / ncols))
    fig, axes = plt.subplots(nrows, ncols, figsize=(4.6 * ncols, 4.4 * nrows + 0.9),
                             squeeze=False)
    for ax, g in zip(axes.ravel(), gaps):
        plot_gap(model, g, ax=ax, colorbar=False)
    for ax in axes.ravel()[len(gaps):]:
        ax.axis("off")
    fig.suptitle(f"{model.name}: stitched gaps in plan view", fontsize=12)
    handles = [Patch(facecolor="0.93", edgecolor="0.6", label="layer TIN"),
               Patch(facecolor="none", edgecolor=FAULT_COLOR, hatch="////", label="fault patch")]
    fig.legend(handles=handles, loc="lower left", ncol=2, fontsize=9, frameon=False)
    fig.tight_layout(rect=(0, 0.05, 0.92, 0.96))
    cax = fig.add_axes((0.93, 0.15, 0.015, 0.7))
    cb = fig.colorbar(ScalarMappable(norm=Normalize(0, 60), cmap=colormaps[GAP_CMAP]), cax=cax)
    cb.set_label("smallest angle of a gap triangle (3D, °)", fontsize=9)
    _save(fig, path)
    return fig


# ----------------------------------------------------------------------------
# Map
# ----------------------------------------------------------------------------

def plot_map(model, path=None, *, sections: Iterable = (), layer: Optional[str] = None):
    """Plan view: elevation of one layer (default: the one with the most
    stitched gaps, i.e. the most faulted seam) with contours, the fault
    surfaces' footprints, the study area and the section lines."""
    plt = _plt()
    from matplotlib.tri import Triangulation
    from matplotlib.collections import PolyCollection
    from matplotlib.lines import Line2D
    import matplotlib.patheffects as pe

    fig, ax = plt.subplots(figsize=(8, 7))
    if layer is None:
        counts = {n: sum(1 for g in model.gaps if g.layer == n) for n in model.surfaces}
        layer = max(model.surfaces, key=lambda n: (counts[n], -list(model.surfaces).index(n)))
    s = model.surfaces[layer]
    V, T = s.vertices, s.triangles
    # Only counter-clockwise triangles: a reverse fault's strip is clockwise.
    area = ((V[T[:, 1], 0] - V[T[:, 0], 0]) * (V[T[:, 2], 1] - V[T[:, 0], 1]) -
            (V[T[:, 1], 1] - V[T[:, 0], 1]) * (V[T[:, 2], 0] - V[T[:, 0], 0]))
    tri = Triangulation(V[:, 0], V[:, 1], T[area > 0])
    tc = ax.tripcolor(tri, V[:, 2], shading="gouraud", cmap="viridis")
    try:
        cs = ax.tricontour(tri, V[:, 2], levels=12, colors="k", linewidths=0.4, alpha=0.45)
        ax.clabel(cs, fontsize=6, fmt="%.0f")
    except Exception:  # contouring a degenerate surface is optional decoration
        pass
    cb = fig.colorbar(tc, ax=ax, shrink=0.8)
    cb.set_label(f"elevation of {layer} (m)")
    halo = [pe.withStroke(linewidth=2.5, foreground="white")]
    for f in model.faults.values():
        ax.add_collection(PolyCollection(f.vertices[f.triangles][:, :, :2], facecolors=FAULT_COLOR,
                                         edgecolors=FAULT_COLOR, linewidths=0.3, alpha=0.6))
        c = f.vertices[:, :2].mean(0)
        ax.annotate(f.name, c, fontsize=9, color="white", fontweight="bold", ha="center",
                    va="center", bbox=dict(boxstyle="round,pad=0.2", fc=FAULT_COLOR, ec="none",
                                           alpha=0.9))
    if model.boundary is not None:
        b = np.asarray(model.boundary)
        ax.plot(np.r_[b[:, 0], b[0, 0]], np.r_[b[:, 1], b[0, 1]], color="k", lw=1.2)
    sections = list(sections)
    for sec in sections:
        if not sec.lines:
            continue
        smin = min(float(ln.s.min()) for ln in sec.lines)
        smax = max(float(ln.s.max()) for ln in sec.lines)
        d = sec.direction
        a, b = sec.origin + smin * d, sec.origin + smax * d
        ax.plot([a[0], b[0]], [a[1], b[1]], color="k", lw=1.4, ls="--")
        ax.annotate(sec.name or f"{sec.azimuth:g}°", b, fontsize=8, fontweight="bold",
                    ha="center", va="center", path_effects=halo,
                    xytext=8 * d, textcoords="offset points")
    (xa, ya), (xb, yb) = V[:, :2].min(0), V[:, :2].max(0)
    pad = 0.07 * max(xb - xa, yb - ya)      # room for the section labels
    ax.set_xlim(xa - pad, xb + pad)
    ax.set_ylim(ya - pad, yb + pad)
    ax.set_aspect("equal")
    _plain_ticks(ax, 5)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"{model.name}: plan view of {layer}", fontsize=11)
    handles = [Line2D([], [], color=FAULT_COLOR, lw=6, alpha=0.6, label="fault footprint")]
    if sections:
        handles.append(Line2D([], [], color="k", lw=1.4, ls="--", label="section line"))
    ax.legend(handles=handles, loc="lower left", fontsize=8, framealpha=0.9)
    _save(fig, path)
    return fig
