"""Can a reader see every legend entry? A check of a drawn Matplotlib figure.

A line named in a legend is hidden when another line is drawn on top of it along
(almost) the same pixels with a style that covers it: same or greater width and no
gaps. Curves that are meant to coincide (methods that agree to plot resolution) are
legible only if the one underneath is wider, the one on top is dashed or dotted, or
the one underneath carries markers of its own. The check works in display (pixel)
coordinates, so log axes and zoomed limits are judged as drawn.
"""

from __future__ import annotations

import numpy as np

# Two curves "coincide" where they are within this many pixels of each other ...
PIXELS = 1.5
# ... at this fraction of the lower curve's points.
COINCIDENT_FRACTION = 0.9


def _solid(line) -> bool:
    return line.get_linestyle() in ("-", "solid")


def _marker(line) -> str | None:
    marker = line.get_marker()
    return None if marker in (None, "None", "none", "", " ") else str(marker)


def _dashes(line):
    # get_linestyle() names a custom dash tuple "--"; the pattern itself tells them apart.
    pattern = getattr(line, "_unscaled_dash_pattern", None)
    return line.get_linestyle() if pattern is None else (line.get_linestyle(), str(pattern))


def _style(line) -> tuple:
    return (str(line.get_color()), _dashes(line), _marker(line))


def _pixels(ax, line) -> np.ndarray:
    x, y = (np.asarray(v, dtype=float) for v in line.get_data())
    with np.errstate(invalid="ignore", divide="ignore"):
        points = ax.transData.transform(np.column_stack([x, y]))
    return points


def _in_view(ax, line) -> bool:
    x, y = (np.asarray(v, dtype=float) for v in line.get_data())
    (x0, x1), (y0, y1) = sorted(ax.get_xlim()), sorted(ax.get_ylim())
    return bool(np.any(np.isfinite(x) & np.isfinite(y) & (x >= x0) & (x <= x1) & (y >= y0) & (y <= y1)))


def _near_set(a: np.ndarray, b: np.ndarray, sample: int = 500) -> float:
    """Fraction of (up to ``sample``) points of a within PIXELS of some point of b."""
    a = a[np.linspace(0, len(a) - 1, min(sample, len(a))).astype(int)]
    near = np.zeros(len(a), dtype=bool)
    for start in range(0, len(b), 4096):
        chunk = b[start:start + 4096]
        d2 = ((a[:, None, :] - chunk[None, :, :]) ** 2).sum(axis=2)
        near |= d2.min(axis=1) <= PIXELS**2
    return float(near.mean())


def _coincide(ax, lower, upper) -> bool:
    """Whether ``upper`` runs over ``lower`` at most of lower's points (in pixels): point
    by point, along x for graphs sampled differently, or as sets of points for curves
    such as orbits, which can trace the same path at different phases."""
    a, b = _pixels(ax, lower), _pixels(ax, upper)
    if a.shape == b.shape:
        ok = np.all(np.isfinite(a), axis=1) & np.all(np.isfinite(b), axis=1)
        if ok.any() and (np.hypot(*(a[ok] - b[ok]).T) <= PIXELS).mean() >= COINCIDENT_FRACTION:
            return True
    # only what is drawn inside the axes can hide anything
    x0, y0, x1, y1 = ax.get_window_extent().extents
    a, b = (v[np.all(np.isfinite(v), axis=1) & (v[:, 0] >= x0) & (v[:, 0] <= x1) & (v[:, 1] >= y0) & (v[:, 1] <= y1)]
            for v in (a, b))
    if len(a) < 2 or len(b) < 2:
        return False
    if np.all(np.diff(a[:, 0]) >= 0) and np.all(np.diff(b[:, 0]) >= 0):
        inside = (a[:, 0] >= b[0, 0]) & (a[:, 0] <= b[-1, 0])
        if inside.mean() < COINCIDENT_FRACTION:
            return False
        gap = np.abs(a[inside, 1] - np.interp(a[inside, 0], b[:, 0], b[:, 1]))
        return bool((gap <= PIXELS).mean() >= COINCIDENT_FRACTION)
    return _near_set(a, b) >= COINCIDENT_FRACTION


def _through_gaps_only(lower, upper) -> bool:
    return not _solid(upper) and lower.get_linewidth() >= upper.get_linewidth()


def _shows_through(lower, upper) -> bool:
    """Whether ``lower`` stays visible under a coinciding ``upper``: wider, or with
    markers of its own, or in the gaps of a dashed or dotted upper line as wide."""
    if lower.get_linewidth() >= 1.5 * upper.get_linewidth() and lower.get_linestyle() not in ("None", "none", ""):
        return True
    lower_marker, upper_marker = _marker(lower), _marker(upper)
    if lower_marker is not None and (lower_marker != upper_marker
                                     or lower.get_markersize() > 1.3 * upper.get_markersize()):
        return True
    return _through_gaps_only(lower, upper)


def problems(fig) -> list[str]:
    """Every way a legend entry of ``fig`` could be unreadable; empty if none."""
    fig.canvas.draw()
    found = []
    figure_legend = bool(fig.legends)
    for n, ax in enumerate(fig.axes):
        title = ax.get_title() or f"axes {n}"
        lines = [ln for ln in ax.get_lines() if not ln.get_label().startswith("_") and ln.get_visible()]
        if len(lines) >= 2 and ax.get_legend() is None and not figure_legend:
            found.append(f"{title}: {len(lines)} labelled lines and no legend")
        for line in lines:
            if not _in_view(ax, line):
                found.append(f"{title}: '{line.get_label()}' has no point inside the axes")
        for i, first in enumerate(lines):
            for second in lines[i + 1:]:
                if _style(first) == _style(second):
                    found.append(f"{title}: '{first.get_label()}' and '{second.get_label()}' share colour, line "
                                 "style and marker")
        order = sorted(lines, key=lambda ln: (ln.get_zorder(), ax.get_lines().index(ln)))
        for i, lower in enumerate(order):
            covering = [upper for upper in order[i + 1:] if _coincide(ax, lower, upper)]
            for upper in covering:
                if not _shows_through(lower, upper):
                    found.append(f"{title}: '{lower.get_label()}' is hidden under '{upper.get_label()}'")
            # The gaps of one dashed line may be filled by another's dashes.
            gaps = [upper for upper in covering if _shows_through(lower, upper)
                    and lower.get_linewidth() < 1.5 * upper.get_linewidth() and _marker(lower) is None]
            if len(gaps) >= 2:
                found.append(f"{title}: '{lower.get_label()}' shows only in the gaps of "
                             + ", ".join(f"'{u.get_label()}'" for u in gaps))
    return found
