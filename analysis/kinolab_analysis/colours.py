"""Planners' colours and the query's start and goal markers, the same in every figure (and
in the 3D viewer, viewer/viewer.js)."""

from __future__ import annotations

# Planners' colours (planner_colours): 20 colours far apart (CIE Lab distance 25 or more, so
# that two planners never look alike), none black, grey or pale (the start and goal markers',
# the page's), none the search tree's edge states (data.EDGE_COLOURS).
# viewer/viewer.js holds the same list for scenes that bring no colours (tests keep them equal).
PALETTE = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2",
           "#17becf", "#000080", "#bcbd22", "#637939", "#a6761d", "#01665e", "#f99379",
           "#dd1c77", "#393b79", "#1b9e77", "#800000", "#e6ab02", "#b3446c"]
# The query's start and goal in every figure: colours no planner has, shapes of their own.
START = {"marker": "o", "color": "black", "ms": 7, "linestyle": "none"}
GOAL = {"marker": "*", "color": "#6c757d", "ms": 12, "markeredgecolor": "black",
        "linestyle": "none"}


def _slot(name: str) -> int:
    """The planner's own place in PALETTE: FNV-1a of its UTF-8 bytes (viewer.js computes the
    same), so that its colour depends on its id alone, not on the other planners."""
    digest = 0x811C9DC5
    for byte in str(name).encode("utf-8"):
        digest = ((digest ^ byte) * 0x01000193) & 0xFFFFFFFF
    return digest % len(PALETTE)


def planner_colours(planners) -> dict[str, str]:
    """One colour per planner id, the same in every figure of every report: its PALETTE slot
    (_slot). Two of these planners on one slot: in id order, the later takes the next free
    slot (all taken: its own again), so one report never draws two planners alike."""
    taken: set[int] = set()
    colours = {}
    for name in sorted(set(map(str, planners))):
        slot = _slot(name)
        for step in range(len(PALETTE)):
            if (slot + step) % len(PALETTE) not in taken:
                slot = (slot + step) % len(PALETTE)
                break
        taken.add(slot)
        colours[name] = PALETTE[slot]
    return colours
