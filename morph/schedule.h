// Per-band timing of a morph (DESIGN.md 3): the weight a_b(t) of image B in band b at time t,
// and a separate shape curve for the geometry.
//
//   linear  every band follows t: exactly the classic warp and cross-dissolve.
//   bands   each level on its own window [start, end] of t, eased by smoothstep. By default the
//           base follows t over the whole morph and finer levels switch over ever shorter windows
//           centred on the middle, so detail never shows both images at once (no ghosting).
//   sharp   every band follows t, and each detail band is then rescaled so its energy is the
//           endpoints' energies interpolated, instead of sagging where two uncorrelated details
//           average out (the washed-out middle frame of a plain dissolve).
//   aware   (the default) ghost-aware: per band and per place, detail that corresponds in A and B
//           (the two agree after the warp: their local correlation c is near 1, on the band
//           itself, pooled with the two coarser bands at that place, or in the two images' pixel
//           detail around that place, each warped to the other; the band finer than the mesh
//           takes the last alone) follows t and keeps its
//           energy, as in sharp; detail that does not correspond (c near 0) is handed
//           over on the band's bands-window with both weights squared, (1 - h)^2 and h^2, so
//           mid-way each image keeps a quarter of its amplitude instead of half: a faint trace,
//           not a doubled picture. Weights in between are mixed by c (Morph measures it).
#pragma once

#include <string>
#include <vector>

namespace tesswave::morph {

enum class ScheduleKind { linear, bands, sharp, aware };

struct Window {
    double start = 0, end = 1;  // 0 <= start < end <= 1
};

struct Schedule {
    ScheduleKind kind = ScheduleKind::aware;
    // bands and aware: windows per level, index 0 the base (T0 values), index 1 + j the details of
    // step j; missing levels take the default ones.
    std::vector<Window> levels = {};
    Window shape = {};  // geometry timing (all kinds)

    // The weight of B for band level `level` (0 base, 1 + j details) of `levels` in all; for
    // aware, that of corresponding detail (t).
    double band_weight(int level, int levels, double t) const;
    // aware: the hand-over curve h of non-corresponding detail (the level's window, eased).
    double handover(int level, int levels, double t) const;
    double shape_weight(double t) const;
};

// smoothstep of t over the window: 0 before, 1 after, C1 in between.
double ease(const Window& w, double t);

// "aware", "linear", "bands" or "sharp" (Error otherwise).
ScheduleKind parse_schedule_kind(const std::string& text);

// Per-level windows from "LEVEL:START-END,..." (e.g. "0:0-1,3:0.4-0.6"); levels not named keep
// their defaults. Error naming the item on bad syntax or windows outside [0,1].
std::vector<Window> parse_level_windows(const std::string& text, int levels);

// A JSON schedule: {"schedule": "bands", "levels": {"0": [0, 1], "3": [0.4, 0.6]},
// "shape": [0, 1]}; `name` prefixes errors.
Schedule parse_schedule_json(const std::string& text, const std::string& name, int levels);

// The default window of a level for the bands and aware schedules.
Window default_window(int level, int levels);

}  // namespace tesswave::morph
