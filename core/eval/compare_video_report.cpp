// The report of `tesswave compare-video`: method names, Bjontegaard deltas, CSV, JSON, the
// summary table and the rate-distortion plots.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <initializer_list>
#include <set>
#include <span>

#include "core/eval/bd_rate.h"
#include "core/eval/compare_video.h"
#include "core/eval/contact_sheet.h"
#include "core/eval/plot.h"
#include "core/math/error.h"
#include "core/math/strings.h"

namespace tesswave::eval {
namespace {

struct MethodName {
    VideoMethod method;
    const char *id, *label;
};

constexpr MethodName kNames[] = {{VideoMethod::moving_mesh, "moving", "moving mesh"},
                                 {VideoMethod::static_mesh, "static", "static mesh"},
                                 {VideoMethod::grid53, "grid53", "grid 5/3"},
                                 {VideoMethod::grid97, "grid97", "grid 9/7"},
                                 {VideoMethod::snow, "snow", "Snow"},
                                 {VideoMethod::vc2, "vc2", "VC-2"},
                                 {VideoMethod::x264, "x264", "x264"}};

const MethodName& names(VideoMethod m) {
    for (const MethodName& n : kNames) {
        if (n.method == m) return n;
    }
    throw Error("compare-video: unknown method");  // unreachable: kNames lists every method
}

// The rate-distortion points of one method on one clip (failed runs left out).
std::vector<RatePoint> curve(const std::vector<VideoRow>& rows, const std::string& clip,
                             VideoMethod method, bool luma) {
    std::vector<RatePoint> points;
    for (const VideoRow& r : rows) {
        if (r.clip == clip && r.method == method_label(method) && r.error.empty()) {
            points.push_back({r.bpp, luma ? r.psnr_y : r.psnr});
        }
    }
    return points;
}

double bd_or_reason(std::span<const RatePoint> reference, std::span<const RatePoint> test,
                    std::string& why_not) {
    try {
        return bd_rate(reference, test);
    } catch (const Error& e) {
        const std::string prefix = "Bjontegaard delta: ";
        why_not = e.what();
        if (why_not.rfind(prefix, 0) == 0) why_not.erase(0, prefix.size());
        return NAN;
    }
}

// "VC-2 failed at 6 of 6 rates", for the methods that failed somewhere; empty if none did.
std::string failures(const std::vector<VideoRow>& rows, const std::string& clip,
                     std::initializer_list<VideoMethod> methods) {
    std::string out;
    for (VideoMethod m : methods) {
        int failed = 0, runs = 0;
        for (const VideoRow& r : rows) {
            if (r.clip != clip || r.method != method_label(m)) continue;
            ++runs;
            failed += !r.error.empty();
        }
        if (failed == 0) continue;
        out += str(out.empty() ? "" : ", ", method_label(m), " failed at ", failed, " of ", runs,
                   " rates");
    }
    return out;
}

std::string csv_field(const std::string& text) {
    if (text.find_first_of(",\"\n") == std::string::npos) return text;
    std::string out = "\"";
    for (char c : text) out += c == '"' ? std::string("\"\"") : std::string(1, c);
    return out + "\"";
}

// Frames per second of a duration, or NaN where it was not measured.
double rate_of(const VideoRow& r, double seconds) {
    return seconds > 0 ? static_cast<double>(r.frames) / seconds : NAN;
}

nlohmann::json number_or_null(double v) {
    return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json();
}

std::string number_or_empty(double v) { return std::isfinite(v) ? str(v) : std::string(); }

std::string row_line(const VideoRow& r) {
    char line[200];
    std::snprintf(line, sizeof line, "  %-6s %-12s", r.rate.c_str(), r.method.c_str());
    if (!r.error.empty()) return str(line, " failed: ", r.error, "\n");
    auto fps = [&](double seconds) {
        const double v = rate_of(r, seconds);
        return std::isfinite(v) ? str(std::lround(v * 10) / 10.0) : std::string("-");
    };
    std::snprintf(line + std::strlen(line), sizeof line - std::strlen(line),
                  " %7.4f %8.1f %7.2f %7.2f %7.4f %8s %8s %8s  ", r.bpp, r.kbps, r.psnr_y, r.psnr,
                  r.ssim, fps(r.encode_s).c_str(), fps(r.decode_s).c_str(), fps(r.total_s).c_str());
    return str(line, r.setting, "\n");
}

std::string bd_line(const BdRow& b) {
    auto cell = [](double v) {
        char c[32];
        if (std::isnan(v)) return std::string("      n/a");
        std::snprintf(c, sizeof c, "%+8.1f%%", v);
        return std::string(c);
    };
    const std::string why = b.why_not_y == b.why_not ? b.why_not_y
                            : b.why_not_y.empty()    ? "PSNR: " + b.why_not
                            : b.why_not.empty()      ? "PSNR-Y: " + b.why_not_y
                                                : "PSNR-Y: " + b.why_not_y + "; PSNR: " + b.why_not;
    char line[100];
    std::snprintf(line, sizeof line, "  %-24s %s %s", b.method.c_str(), cell(b.psnr_y).c_str(),
                  cell(b.psnr).c_str());
    return str(line, why.empty() ? "" : "  ", why, "\n");
}

Image plot_panel(const ClipInfo& clip, const std::vector<VideoRow>& rows,
                 const std::vector<VideoMethod>& methods, bool luma) {
    std::vector<PlotSeries> series;
    for (VideoMethod m : methods) {
        std::vector<RatePoint> points = curve(rows, clip.name, m, luma);
        std::sort(points.begin(), points.end(),
                  [](const RatePoint& a, const RatePoint& b) { return a.rate < b.rate; });
        PlotSeries s{method_label(m), {}, {}};
        for (const RatePoint& p : points) {
            s.x.push_back(p.rate);
            s.y.push_back(p.psnr);
        }
        series.push_back(std::move(s));
    }
    return draw_line_plot(
        series, {.title = str(clip.name, ", ", clip.frames,
                              " frames: ", luma ? "luma (BT.601 Y)" : "all channels (R, G, B)"),
                 .x_label = "bits per pixel (whole stream)",
                 .y_label = luma ? "PSNR-Y (dB), mean over frames" : "PSNR (dB), mean over frames",
                 .width = 800,
                 .height = 560,
                 .log_x = true});
}

}  // namespace

const char* method_id(VideoMethod m) { return names(m).id; }
const char* method_label(VideoMethod m) { return names(m).label; }

VideoMethod method_from_id(const std::string& id) {
    for (const MethodName& n : kNames) {
        if (id == n.id) return n.method;
    }
    throw Error(str("--methods: unknown method '", id,
                    "' (moving, static, grid53, grid97, snow, vc2, x264)"));
}

std::vector<BdRow> bd_rates(const std::vector<ClipInfo>& clips, const std::vector<VideoRow>& rows,
                            const std::vector<VideoMethod>& methods) {
    std::vector<BdRow> out;
    for (VideoMethod reference : kBdReferences) {
        if (std::find(methods.begin(), methods.end(), reference) == methods.end()) continue;
        for (const ClipInfo& clip : clips) {
            const auto ref_y = curve(rows, clip.name, reference, true);
            const auto ref = curve(rows, clip.name, reference, false);
            for (VideoMethod m : methods) {
                if (m == reference) continue;
                BdRow b{clip.name, method_label(m), method_label(reference), NAN, NAN, {}, {}};
                b.psnr_y = bd_or_reason(ref_y, curve(rows, clip.name, m, true), b.why_not_y);
                b.psnr = bd_or_reason(ref, curve(rows, clip.name, m, false), b.why_not);
                const std::string failed = failures(rows, clip.name, {reference, m});
                for (std::string* why : {&b.why_not_y, &b.why_not}) {
                    if (!why->empty() && !failed.empty()) *why = failed + ": " + *why;
                }
                out.push_back(std::move(b));
            }
        }
    }
    return out;
}

std::string results_csv(const std::vector<VideoRow>& rows) {
    std::string out =
        "clip,method,rate,target_bpp,bytes,bpp,kbps,frames,psnr_y,psnr,ssim,encode_fps,"
        "decode_fps,total_fps,setting,tries,error\n";
    auto fps = [](const VideoRow& r, double s) { return number_or_empty(rate_of(r, s)); };
    for (const VideoRow& r : rows) {
        const bool ok = r.error.empty();
        out += str(csv_field(r.clip), ",", r.method, ",", r.rate, ",", r.target_bpp, ",");
        out += ok ? str(r.bytes, ",", r.bpp, ",", r.kbps, ",", r.frames, ",", r.psnr_y, ",", r.psnr,
                        ",", r.ssim, ",", fps(r, r.encode_s), ",", fps(r, r.decode_s), ",",
                        fps(r, r.total_s), ",")
                  : std::string(",,,,,,,,,,");
        out += str(csv_field(r.setting), ",", r.tries, ",", csv_field(r.error), "\n");
    }
    return out;
}

std::string bd_csv(const std::vector<BdRow>& bd) {
    std::string out = str("clip,method,reference,bd_rate_psnr_y,bd_rate_psnr,why_not_y,why_not\n");
    for (const BdRow& b : bd) {
        out += str(csv_field(b.clip), ",", b.method, ",", b.reference, ",",
                   number_or_empty(b.psnr_y), ",", number_or_empty(b.psnr), ",",
                   csv_field(b.why_not_y), ",", csv_field(b.why_not), "\n");
    }
    return out;
}

nlohmann::json results_json(const std::vector<ClipInfo>& clips, const std::vector<VideoRow>& rows,
                            const std::vector<BdRow>& bd, const nlohmann::json& settings) {
    nlohmann::json j = {{"settings", settings},
                        {"clips", nlohmann::json::array()},
                        {"rows", nlohmann::json::array()},
                        {"bd_rate", nlohmann::json::array()}};
    for (const ClipInfo& c : clips) {
        j["clips"].push_back({{"path", c.path},
                              {"name", c.name},
                              {"width", c.width},
                              {"height", c.height},
                              {"fps", c.fps},
                              {"frames", c.frames},
                              {"shown_frame", c.shown_frame},
                              {"source_codec", c.source_codec},
                              {"source_bpp", number_or_null(c.source_bpp > 0 ? c.source_bpp : NAN)},
                              {"source_note", source_note(c)}});
    }
    for (const VideoRow& r : rows) {
        nlohmann::json row = {{"clip", r.clip},       {"method", r.method},
                              {"rate", r.rate},       {"target_bpp", r.target_bpp},
                              {"setting", r.setting}, {"tries", r.tries}};
        if (!r.error.empty()) {
            row["error"] = r.error;
        } else {
            row.update({{"bytes", r.bytes},
                        {"bpp", r.bpp},
                        {"kbps", r.kbps},
                        {"frames", r.frames},
                        {"psnr_y", r.psnr_y},
                        {"psnr", r.psnr},
                        {"ssim", r.ssim},
                        {"encode_fps", number_or_null(rate_of(r, r.encode_s))},
                        {"decode_fps", number_or_null(rate_of(r, r.decode_s))},
                        {"total_fps", number_or_null(rate_of(r, r.total_s))}});
        }
        j["rows"].push_back(std::move(row));
    }
    for (const BdRow& b : bd) {
        j["bd_rate"].push_back({{"clip", b.clip},
                                {"method", b.method},
                                {"reference", b.reference},
                                {"psnr_y", number_or_null(b.psnr_y)},
                                {"psnr", number_or_null(b.psnr)},
                                {"why_not_y", b.why_not_y},
                                {"why_not", b.why_not}});
    }
    return j;
}

namespace {

// " at 0.086 bpp", or "" when the source's rate is unknown.
std::string source_rate(const ClipInfo& c) {
    return c.source_bpp > 0 ? str(" at ", std::lround(c.source_bpp * 1000) / 1000.0, " bpp") : "";
}

}  // namespace

std::string source_note(const ClipInfo& c) {
    static const std::set<std::string, std::less<>> kBlockCodecs = {
        "av1",        "h263",  "h264",   "hevc", "mjpeg", "mpeg1video",
        "mpeg2video", "mpeg4", "theora", "vc1",  "vp8",   "vp9"};
    if (!kBlockCodecs.contains(c.source_codec)) return "";
    return str(c.name, " is ", c.source_codec, source_rate(c),
               ": a peer of its kind (x264 on H.264) can code the source's own blocks again, at "
               "rates near the source's almost exactly; a crop off its block grid (ffmpeg -vf "
               "crop=iw-16:ih-16:3:5) compares without that");
}

std::string summary_table(const std::vector<ClipInfo>& clips, const std::vector<VideoRow>& rows,
                          const std::vector<BdRow>& bd) {
    std::string s;
    for (const ClipInfo& c : clips) {
        const std::string source =
            c.source_codec.empty() ? "" : str("; source ", c.source_codec, source_rate(c));
        s +=
            str(c.name, ": ", c.width, "x", c.height, ", ", c.frames, " frames at ", c.fps, " fps",
                source, "; means over the frames; f/s: frames a second (all: encode and decode)\n");
        if (const std::string note = source_note(c); !note.empty())
            s += str("  note: ", note, "\n");
        s += "  rate   method           bpp     kbps  PSNR-Y    PSNR    SSIM  enc f/s  dec f/s"
             "  all f/s  setting\n";
        for (const VideoRow& r : rows) {
            if (r.clip == c.name) s += row_line(r);
        }
        // One reason for every row (too few rates) is said once.
        std::vector<const BdRow*> mine;
        for (const BdRow& b : bd) {
            if (b.clip == c.name) mine.push_back(&b);
        }
        const bool one_reason =
            !mine.empty() && std::all_of(mine.begin(), mine.end(), [&](const BdRow* b) {
                return std::isnan(b->psnr_y) && std::isnan(b->psnr) &&
                       b->why_not_y == mine[0]->why_not_y && b->why_not == mine[0]->why_not_y;
            });
        if (one_reason) {
            s += str("  BD-rates: none (", mine[0]->why_not_y, ")\n");
            continue;
        }
        for (VideoMethod reference : kBdReferences) {
            std::string lines;
            for (const BdRow* b : mine) {
                if (b->reference == method_label(reference)) lines += bd_line(*b);
            }
            if (lines.empty()) continue;
            char head[100];
            std::snprintf(head, sizeof head, "  BD-rate against %-16s    PSNR-Y      PSNR\n",
                          method_label(reference));
            s += str(head, lines);
        }
    }
    return s;
}

Image rd_plot(const ClipInfo& clip, const std::vector<VideoRow>& rows,
              const std::vector<VideoMethod>& methods) {
    return contact_sheet(
        {plot_panel(clip, rows, methods, true), plot_panel(clip, rows, methods, false)}, {"", ""});
}

}  // namespace tesswave::eval
