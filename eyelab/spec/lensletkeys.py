"""``[lens.lenslets]``'s rows of the spec's reference (:data:`eyelab.spec.schema.KEYS`),
apart from its parser (:mod:`eyelab.spec.lenslets`, which reads the schema): a lenslet
array on the lens's front surface (the myopia-control designs,
:mod:`eyelab.optics.lens.lenslets`).

``layout`` = ``"honeycomb"`` (``pitch_mm``, within ``clear_zone_mm`` to ``zone_mm``),
``"rings"`` (``ring_diameters_mm``, ``per_ring`` counts or as many as fit contiguously) or
``"list"`` (``centres_mm``); ``diameter_mm`` and ``add_d`` (each lenslet's add as worn,
designed); ``conic`` of the lenslets' added sag. A layout whose lenslets overlap, reach
beyond the lens, or hold none is refused naming the key that places them.
"""

from __future__ import annotations

from eyelab.optics.lens.lenslets import LAYOUTS, MAX_LENSLETS
from eyelab.optics.lens.lenslets import LIMITS as LENSLET_LIMITS

WHERE = "lens.lenslets"
#: The keys each layout reads (besides the common ones).
LAYOUT_KEYS = {"honeycomb": ("pitch_mm", "clear_zone_mm", "zone_mm"),
               "rings": ("ring_diameters_mm", "per_ring"), "list": ("centres_mm",)}
COMMON_KEYS = ("layout", "add_d", "diameter_mm", "conic")
ALLOWED = set(COMMON_KEYS).union(*LAYOUT_KEYS.values())
#: A DIMS-like honeycomb (docs/SCIENCE.md §12b: 396 lenslets of +3.50 D, 1.03 mm, in the
#: annulus 9.4-33 mm; the pitch is not published: every pitch in 1.419-1.435 mm and
#: 1.447-1.453 mm puts 396 lattice lenslets there, and 1.43 mm is taken).
DIMS_LIKE = {"layout": "honeycomb", "add_d": 3.5, "diameter_mm": 1.03, "pitch_mm": 1.43,
             "clear_zone_mm": 9.4, "zone_mm": 33.0}
#: A HALT-like ring layout (docs/SCIENCE.md §12b: 1,021 contiguous lenslets of 1.12 mm on 11
#: rings around a 9 mm clear zone; the rings' diameters are not published: the first
#: touches the clear zone, and the pitch 2.309 mm is the one that puts 1,021 contiguous
#: lenslets on 11 rings; the lenslets' powers and asphericity are not published either:
#: DIMS's +3.50 D, spherical).
HALT_LIKE = {"layout": "rings", "add_d": 3.5, "diameter_mm": 1.12,
             "ring_diameters_mm": [round(10.12 + 2 * 2.309 * k, 3) for k in range(11)]}
#: A spec with lenslets (the schema's examples, the tests and the corpus read it).
BASE = {"lens": {"rx": "-3.00 DS", "lenslets": DIMS_LIKE}}
RINGS_BASE = {"lens": {"rx": "-3.00 DS", "lenslets": {
    "layout": "rings", "add_d": 3.5, "diameter_mm": 1.12,
    "ring_diameters_mm": [10.0, 12.5, 15.0]}}}
LIST_BASE = {"lens": {"rx": "-3.00 DS", "lenslets": {
    "layout": "list", "add_d": 3.5, "diameter_mm": 1.0, "centres_mm": [[6.0, 0.0]]}}}
LENSLET_TABLE = ("`[lens.lenslets]` (a lenslet array on the front surface: the myopia-control "
                 "designs; docs/guide/lenslets.md)")
LENSLET_KEYS = (
    (("lens", "lenslets", "text", "", "none", "a lenslet array on the front surface: "
      "table `[lens.lenslets]`"), {"range_text": "a table"}),
    ((WHERE, "layout", "choice", "", "required", "honeycomb: a hexagonal lattice in an "
      "annulus, its rows along x (the wearer's horizontal) and one lattice point on the "
      "lens's centre; rings: concentric rings about the centre, each ring's first lenslet "
      "on +x, alternate rings turned by half a step; list: centres one by one; at most "
      f"{MAX_LENSLETS:,} lenslets (5 × the densest design in production)"),
     {"choices": LAYOUTS, "base": BASE,
      "choice_base": {"rings": RINGS_BASE, "list": LIST_BASE}}),
    ((WHERE, "add_d", "number", "D", "required", "each lenslet's add as worn: the mean "
      "power along the line of sight through its centre less the carrier's there "
      "(designed; not 0)"), {"base": BASE}),
    ((WHERE, "diameter_mm", "number", "mm", "required", "each lenslet's diameter, in the "
      "lens's x, y plane; inside it a conicoid sag is added to the carrier's along the "
      "lens's axis, lowered to meet the carrier at the rim"),
     {"base": BASE, "edges": False}),
    ((WHERE, "conic", "number", "", "0 (spherical)", "conic constant of the lenslets' "
      "added sag (aspherical lenslets)"), {"base": BASE}),
    ((WHERE, "pitch_mm", "number", "mm", "required (honeycomb)", "centre to centre; not "
      "below `diameter_mm` (a count fixes a range of pitches: 396 DIMS-like lenslets for "
      "any pitch in 1.419–1.435 or 1.447–1.453 mm)"), {"base": BASE, "edges": False}),
    ((WHERE, "clear_zone_mm", "number", "mm", "0", "honeycomb: the clear centre's "
      "diameter (no lenslet reaches into it)"), {"base": BASE, "edges": False}),
    ((WHERE, "zone_mm", "number", "mm", "the lens's diameter less 2 mm", "honeycomb: the "
      "treatment zone's outer diameter"), {"base": BASE, "edges": False}),
    ((WHERE, "ring_diameters_mm", "text", "mm", "required (rings)", "the rings' "
      "diameters (a list)"), {"range_text": "a list of numbers in [1, 90]",
                              "base": RINGS_BASE}),
    ((WHERE, "per_ring", "text", "", "as many as fit", "rings: lenslets on each ring (a "
      "list of integers, one per ring); else as many as fit contiguously: the most whose "
      "chords between neighbours are at least `diameter_mm`"),
     {"range_text": "integers in [1, 2000]", "base": RINGS_BASE}),
    ((WHERE, "centres_mm", "text", "mm", "required (list)", "the lenslets' centres [[x, y], "
      "...] on the lens (x toward the wearer's right, y up)"),
     {"range_text": "pairs in [-45, 45]", "base": LIST_BASE}),
)


__all__ = ["ALLOWED", "BASE", "LAYOUT_KEYS", "LENSLET_KEYS", "LENSLET_LIMITS",
           "LENSLET_TABLE", "WHERE"]
