#include "schedule.h"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/math/error.h"
#include "core/math/strings.h"

namespace tesswave::morph {
namespace {

Window checked(double start, double end, const std::string& what) {
    if (!(start >= 0 && end <= 1 && start < end)) {
        throw Error(
            str(what, ": window [", start, ", ", end, "] must satisfy 0 <= start < end <= 1"));
    }
    return {start, end};
}

}  // namespace

double ease(const Window& w, double t) {
    const double s = std::clamp((t - w.start) / (w.end - w.start), 0.0, 1.0);
    return s * s * (3 - 2 * s);
}

Window default_window(int level, int levels) {
    // The base over the whole morph; the finest level over the middle fifth.
    const double f = levels > 1 ? static_cast<double>(level) / (levels - 1) : 0.0;
    const double half = 0.5 - 0.4 * f;
    return {0.5 - half, 0.5 + half};
}

double Schedule::band_weight(int level, int count, double t) const {
    if (kind != ScheduleKind::bands) return t;
    const Window w =
        level < static_cast<int>(levels.size()) ? levels[level] : default_window(level, count);
    return ease(w, t);
}

double Schedule::handover(int level, int count, double t) const {
    const Window w =
        level < static_cast<int>(levels.size()) ? levels[level] : default_window(level, count);
    return ease(w, t);
}

double Schedule::shape_weight(double t) const {
    if (shape.start == 0 && shape.end == 1) return t;  // the plain linear shape curve
    return ease(shape, t);
}

ScheduleKind parse_schedule_kind(const std::string& text) {
    if (text == "linear") return ScheduleKind::linear;
    if (text == "bands") return ScheduleKind::bands;
    if (text == "sharp") return ScheduleKind::sharp;
    if (text == "aware") return ScheduleKind::aware;
    throw Error(str("unknown schedule '", text, "' (aware, linear, bands or sharp)"));
}

std::vector<Window> parse_level_windows(const std::string& text, int levels) {
    std::vector<Window> out;
    for (int l = 0; l < levels; ++l) out.push_back(default_window(l, levels));
    std::stringstream in(text);
    std::string item;
    while (std::getline(in, item, ',')) {
        int level = -1;
        double start = 0, end = 0;
        char colon = 0, dash = 0, extra = 0;
        std::istringstream one(item);
        if (!(one >> level >> colon >> start >> dash >> end) || colon != ':' || dash != '-' ||
            (one >> extra)) {
            throw Error(str("--bands: '", item, "' is not LEVEL:START-END"));
        }
        if (level < 0 || level >= levels) {
            throw Error(str("--bands: level ", level, " is outside 0..", levels - 1));
        }
        out[level] = checked(start, end, str("--bands level ", level));
    }
    return out;
}

Schedule parse_schedule_json(const std::string& text, const std::string& name, int levels) {
    nlohmann::json j;
    try {
        j = nlohmann::json::parse(text);
    } catch (const nlohmann::json::exception& e) {
        throw Error(str(name, ": not JSON (", e.what(), ")"));
    }
    if (!j.is_object()) throw Error(str(name, ": a schedule is a JSON object"));
    Schedule s;
    try {
        s.kind = parse_schedule_kind(j.value("schedule", std::string("bands")));
        for (int l = 0; l < levels; ++l) s.levels.push_back(default_window(l, levels));
        if (j.contains("levels")) {
            for (const auto& [key, value] : j.at("levels").items()) {
                const int level = std::stoi(key);
                if (level < 0 || level >= levels || !value.is_array() || value.size() != 2) {
                    throw Error(
                        str("level '", key, "' must be 0..", levels - 1, " with [start, end]"));
                }
                s.levels[level] =
                    checked(value[0].get<double>(), value[1].get<double>(), str("level ", level));
            }
        }
        if (j.contains("shape")) {
            const auto& v = j.at("shape");
            if (!v.is_array() || v.size() != 2) throw Error("shape must be [start, end]");
            s.shape = checked(v[0].get<double>(), v[1].get<double>(), "shape");
        }
    } catch (const Error& e) {
        throw Error(str(name, ": ", e.what()));
    } catch (const std::exception& e) {
        throw Error(str(name, ": ", e.what()));
    }
    return s;
}

}  // namespace tesswave::morph
