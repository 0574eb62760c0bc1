#include "morph.h"

#include <algorithm>
#include <cmath>
#include <memory>

#include "core/math/error.h"
#include "core/math/hierarchy.h"
#include "core/math/lifting.h"
#include "core/math/parallel.h"
#include "core/math/parametrization.h"
#include "core/math/project.h"
#include "core/math/render.h"
#include "core/math/sampling.h"
#include "core/math/strings.h"
#include "core/math/validate.h"
#include "geometry.h"

namespace tesswave::morph {
namespace {

using Planes = std::vector<std::vector<float>>;

std::vector<std::span<float>> spans(Planes& p) { return {p.begin(), p.end()}; }

// Channels for the morph: RGB (grey widened) plus alpha when both images have it.
Image with_channels(const Image& image, int channels) {
    Image out = make_image(image.width, image.height, channels, image.format);
    for (int c = 0; c < channels; ++c) {
        const int from = image.channels() < 3 ? 0 : c;
        out.planes[c] =
            c < 3 ? image.planes[std::min(from, image.channels() - 1)] : image.planes[3];
    }
    return out;
}

std::vector<Vec2> scaled(const Mesh& m, double W, double H) {
    std::vector<Vec2> v = m.vertices;
    const double sx = W / m.width, sy = H / m.height;
    for (Vec2& p : v) p = {p.x == m.width ? W : p.x * sx, p.y == m.height ? H : p.y * sy};
    return v;
}

// How much detail with local correlation c counts as corresponding: none up to 0.1, all from 0.4.
template <class T>
T corresponding(T c) {
    return std::clamp((c - T(0.1)) / T(0.3), T(0), T(1));
}

// The aware schedule's weights of A and B for detail that corresponds to the degree k, with local
// energies aa and bb and inner product ab, at t: corresponding detail follows t with its energy
// kept (the gain, at most 2); the rest is handed over with the weights (ha, hb) of its level.
// Float for the coefficients (a loop the compiler vectorizes), double for the residual band.
template <class T>
std::pair<T, T> aware_weights(T k, T aa, T bb, T ab, T t, T ha, T hb) {
    const T u = 1 - t;
    const T mixed = u * u * aa + t * t * bb + 2 * t * u * ab;
    const T target = u * aa + t * bb;
    // mixed is 0 only where the detail is 0 or exactly anti-correlated (k = 0): no branch, so
    // that the loop vectorizes.
    const T gain = std::min(T{2}, std::sqrt(target / std::max(mixed, T{1e-30})));
    return {k * gain * u + (1 - k) * ha, k * gain * t + (1 - k) * hb};
}

// The hand-over weights of non-corresponding detail on a level whose curve is at h: (1 - h)^p
// and h^p, from p = 1 for the coarsest detail (a soft blend of broad shading is no ghost) to
// p = 2 for the finest (edges are what doubles).
std::pair<double, double> handover_weights(double h, double p) {
    return {std::pow(1 - h, p), std::pow(h, p)};
}

}  // namespace

int morph_levels(const Mesh& mesh_a, int width, int height, const MorphOptions& options) {
    // Sample counts per level depend on the topology alone, not on where the vertices are.
    return options.levels > 0 ? options.levels
                              : level_for_density(mesh_a, width * height, options.density);
}

// A flat 8192x8192 PNG of 212 KB ran 75 s and 14.6 GiB before the hierarchy refused "level 5
// needs 119093569 samples", naming no file.
void check_sample_estimate(const std::string& name, int width, int height, double density,
                           int levels) {
    const double samples = density * width * height;
    const int64_t limit = HierarchyOptions{}.max_samples;
    if (levels == 0 && samples > 2.0 * static_cast<double>(limit)) {
        throw Error(str(name, ": a morph of ", width, "x", height, " pixels at ", density,
                        " samples a pixel needs about ", static_cast<int64_t>(samples),
                        " mesh samples (the limit is ", limit, "); lower --density or --size"));
    }
}

// The exact count, once the pair's mesh is known.
void check_samples(const std::string& name, const Mesh& mesh, int width, int height,
                   const MorphOptions& options) {
    const int levels = morph_levels(mesh, width, height, options);
    const int64_t samples = sample_count(mesh, levels), limit = HierarchyOptions{}.max_samples;
    if (samples > limit) {
        throw Error(str(name, ": a morph of ", width, "x", height, " pixels on this mesh has ",
                        samples, " samples at level ", levels, " (the limit is ", limit,
                        "); lower --density, -J or --size"));
    }
}

Morph::Morph(const Image& a, const Image& b, const Mesh& mesh_a, const Mesh& mesh_b,
             const MorphOptions& options)
    : options_(options) {
    options_.residual = options.residual && options.sampling == Sampling::point;
    if (mesh_a.num_vertices() != mesh_b.num_vertices() ||
        mesh_a.face_offsets != mesh_b.face_offsets || mesh_a.face_corners != mesh_b.face_corners) {
        throw Error("morph: the two meshes do not share one topology");
    }
    require_valid(mesh_a, "mesh on A");
    require_valid(mesh_b, "mesh on B");
    if (mesh_a.width != a.width || mesh_a.height != a.height || mesh_b.width != b.width ||
        mesh_b.height != b.height) {
        throw Error("morph: each mesh must cover its image's pixel rectangle");
    }
    width_ = options.width > 0 ? options.width : a.width;
    height_ = options.height > 0 ? options.height : a.height;
    topology_ = mesh_a;
    topology_.width = width_;
    topology_.height = height_;
    va_ = scaled(mesh_a, width_, height_);
    vb_ = scaled(mesh_b, width_, height_);
    topology_.vertices = va_;
    const int J = morph_levels(mesh_a, width_, height_, options);
    report(options.progress, 0.0, "hierarchy");
    hierarchy_ = build_hierarchy(topology_, {.levels = J, .finest_topology = false});
    preview_ = build_hierarchy(topology_, {.levels = std::max(1, J - 2), .finest_topology = false});
    const int channels = (a.channels() == 4 && b.channels() == 4) ? 4 : 3;
    report(options.progress, 0.2, "sampling");
    const Image image_a = with_channels(a, channels), image_b = with_channels(b, channels);
    samples_a_ = place_image(image_a, hierarchy_, mesh_a.vertices, options.sampling);
    samples_b_ = place_image(image_b, hierarchy_, mesh_b.vertices, options.sampling);
    report(options.progress, 0.5, "residuals");
    const bool aware = options_.schedule.kind == ScheduleKind::aware;
    if (options_.residual || aware) {
        quads_a_ = quad_maps(t1_quads(hierarchy_, mesh_a.vertices));
        quads_b_ = quad_maps(t1_quads(hierarchy_, mesh_b.vertices));
    }
    std::vector<RenderPlan> plans;  // aware: A's and B's, for warping each image to the other
    for (int k = 0; k < 2; ++k) {
        if (!options_.residual && !aware) break;
        const Image& image = k == 0 ? image_a : image_b;
        const Mesh& mesh = k == 0 ? mesh_a : mesh_b;
        RenderPlan plan = plan_render(hierarchy_, mesh.vertices, mesh.width, mesh.height,
                                      image.width, image.height);
        if (options_.residual) {
            const auto& samples = k == 0 ? samples_a_ : samples_b_;
            std::vector<std::span<const float>> in(samples.begin(), samples.end());
            const Image back = render(plan, in, SampleFormat::f32);
            Image r = image;
            for (int c = 0; c < channels; ++c) {
                for (size_t i = 0; i < r.planes[c].size(); ++i) r.planes[c][i] -= back.planes[c][i];
            }
            (k == 0 ? residual_a_ : residual_b_) = std::move(r);
        }
        if (aware) plans.push_back(std::move(plan));
    }
    if (aware) {
        // placed_: per T_J sample, the pixel agreement of A's and B's detail measured in A's
        // pixels (B warped to A) and in B's (A warped to B), each read at the sample's place
        // there, and how far their mean counts as corresponding, so that A and B count alike;
        // with the residual warp, the residuals' local energies in A's pixels.
        std::vector<std::vector<float>> maps;
        maps.push_back(std::move(
            detail_agreement(image_a, warped_through(plans[0], quads_b_, image_b)).planes[0]));
        if (options_.residual) {
            for (auto& plane :
                 residual_energies(residual_a_, warped_through(plans[0], quads_b_, residual_b_))) {
                maps.push_back(std::move(plane));
            }
        }
        const Image in_b = detail_agreement(image_b, warped_through(plans[1], quads_a_, image_a));
        const std::vector<Vec2> position_a = refine_positions(hierarchy_, mesh_a.vertices, J);
        const std::vector<Vec2> position_b = refine_positions(hierarchy_, mesh_b.vertices, J);
        const size_t n = position_a.size();
        placed_.assign(maps.size(), std::vector<float>(n));
        parallel_for(
            static_cast<int64_t>(n),
            [&](int64_t begin, int64_t end) {
                for (int64_t i = begin; i < end; ++i) {
                    const Tap ta = bilinear_tap(image_a.width, image_a.height, 1.0, position_a[i]);
                    for (size_t k = 0; k < maps.size(); ++k)
                        placed_[k][i] = bilinear_at(ta, maps[k].data());
                    const Tap tb = bilinear_tap(image_b.width, image_b.height, 1.0, position_b[i]);
                    const double mean =
                        0.5 * (placed_[0][i] + bilinear_at(tb, in_b.planes[0].data()));
                    placed_[0][i] = static_cast<float>(corresponding(mean));
                }
            },
            16384);
    }
    report(options.progress, 0.8, "transforms");
    coeff_a_ = samples_a_;
    coeff_b_ = samples_b_;
    forward_transform(hierarchy_, spans(coeff_a_));
    forward_transform(hierarchy_, spans(coeff_b_));
    for (const Planes* w : {&coeff_a_, &coeff_b_}) {
        auto& energy = w == &coeff_a_ ? energy_a_ : energy_b_;
        energy.assign(channels, std::vector<double>(J, 0.0));
        for (int c = 0; c < channels; ++c) {
            for (int j = 0; j < J; ++j) {
                for (int32_t i = hierarchy_.num_samples(j); i < hierarchy_.num_samples(j + 1);
                     ++i) {
                    energy[c][j] += double{(*w)[c][i]} * (*w)[c][i];
                }
            }
        }
    }
    if (options_.schedule.kind == ScheduleKind::aware) measure_agreement();
}

namespace {

// A grid of cells about two sample spacings of one level wide, which the level's values are
// splatted onto and read back from with bilinear weights: a local mean over a few neighbours.
struct LevelGrid {
    double cell = 1;
    int cols = 0, rows = 0;

    LevelGrid(double width, double height, int32_t samples)
        : cell(2 * std::sqrt(width * height / samples)),
          cols(static_cast<int>(width / cell) + 2),
          rows(static_cast<int>(height / cell) + 2) {}
    size_t size() const { return static_cast<size_t>(cols) * rows; }
    // f(node, weight) for the four nodes around p.
    template <class F>
    void corners(Vec2 p, F&& f) const {
        const double gx = std::clamp(p.x / cell, 0.0, cols - 1.0 - 1e-9);
        const double gy = std::clamp(p.y / cell, 0.0, rows - 1.0 - 1e-9);
        const int x0 = static_cast<int>(gx), y0 = static_cast<int>(gy);
        const double fx = gx - x0, fy = gy - y0;
        const size_t k = static_cast<size_t>(y0) * cols + x0;
        f(k, (1 - fx) * (1 - fy));
        f(k + 1, fx * (1 - fy));
        f(k + cols, (1 - fx) * fy);
        f(k + cols + 1, fx * fy);
    }
};

// How many coarser levels a place's correspondence is inherited from (measure_agreement).
constexpr int kInheritedLevels = 2;

}  // namespace

void Morph::measure_agreement() {
    // Each level's detail energies and inner products, splatted onto the level's grid and read
    // back: a local mean over a few neighbours on the level, at the cost of two passes.
    const int J = levels();
    const int32_t n = hierarchy_.num_samples(J);
    local_a_.assign(n, 0.0f);
    local_b_.assign(n, 0.0f);
    local_ab_.assign(n, 0.0f);
    corresponding_.assign(n, 0.0f);
    const std::vector<Vec2> position = refine_positions(hierarchy_, va_, J);
    // The two coarser levels' local energies and inner products, on their grids.
    std::vector<std::pair<LevelGrid, std::vector<double>>> coarser;
    for (int level = 1; level <= J; ++level) {
        const int32_t begin = hierarchy_.num_samples(level - 1),
                      end = hierarchy_.num_samples(level);
        const LevelGrid grid(width_, height_, end);
        std::vector<double> sums(3 * grid.size(), 0.0);
        for (int32_t i = begin; i < end; ++i) {
            double aa = 0, bb = 0, ab = 0;
            for (size_t c = 0; c < coeff_a_.size(); ++c) {
                aa += double{coeff_a_[c][i]} * coeff_a_[c][i];
                bb += double{coeff_b_[c][i]} * coeff_b_[c][i];
                ab += double{coeff_a_[c][i]} * coeff_b_[c][i];
            }
            grid.corners(position[i], [&](size_t k, double w) {
                sums[3 * k] += w * aa;
                sums[3 * k + 1] += w * bb;
                sums[3 * k + 2] += w * ab;
            });
        }
        // Read back per sample: independent, so shared among the cores.
        parallel_for(
            end - begin,
            [&](int64_t from, int64_t to) {
                for (int64_t i = begin + from; i < begin + to; ++i) {
                    double aa = 0, bb = 0, ab = 0;
                    grid.corners(position[i], [&](size_t k, double w) {
                        aa += w * sums[3 * k];
                        bb += w * sums[3 * k + 1];
                        ab += w * sums[3 * k + 2];
                    });
                    local_a_[i] = static_cast<float>(aa);
                    local_b_[i] = static_cast<float>(bb);
                    local_ab_[i] = static_cast<float>(ab);
                    // Detail corresponds where it does on its own level, where this level and the
                    // two coarser ones correspond taken together (the fine texture of two faces
                    // does not correlate coefficient by coefficient where the features it sits on
                    // do), or where the two images' pixel detail agrees at its place (placed_).
                    for (const auto& level_sums : coarser) {
                        const std::vector<double>& coarse = level_sums.second;
                        level_sums.first.corners(position[i], [&](size_t k, double w) {
                            aa += w * coarse[3 * k];
                            bb += w * coarse[3 * k + 1];
                            ab += w * coarse[3 * k + 2];
                        });
                    }
                    const double pooled =
                        aa > 0 && bb > 0 ? std::clamp(ab / std::sqrt(aa * bb), 0.0, 1.0) : 0.0;
                    corresponding_[i] = static_cast<float>(
                        std::max({corresponding(correspondence(static_cast<int32_t>(i))),
                                  corresponding(pooled), double{placed_[0][i]}}));
                }
            },
            4096);
        coarser.emplace_back(grid, std::move(sums));
        if (coarser.size() > static_cast<size_t>(kInheritedLevels)) coarser.erase(coarser.begin());
    }
}

double Morph::correspondence(int32_t i) const {
    if (local_a_.empty() || i < hierarchy_.num_samples(0)) return 0;
    const double aa = local_a_[i], bb = local_b_[i];
    return aa > 0 && bb > 0 ? std::clamp(local_ab_[i] / std::sqrt(aa * bb), 0.0, 1.0) : 0.0;
}

std::vector<Vec2> Morph::geometry(double t) const {
    return interpolate_geometry(topology_, va_, vb_, options_.schedule.shape_weight(t));
}

Planes Morph::blended(double t) const {
    if (!(t >= 0 && t <= 1)) throw Error(str("morph: t = ", t, " is outside [0, 1]"));
    const int J = levels();
    const Schedule& s = options_.schedule;
    const size_t channels = coeff_a_.size();
    Planes w(channels);  // every value is written below
    for (auto& plane : w) plane.resize(coeff_a_[0].size());
    for (int level = 0; level <= J; ++level) {
        const int32_t begin = level == 0 ? 0 : hierarchy_.num_samples(level - 1);
        const int32_t end = hierarchy_.num_samples(level == 0 ? 0 : level);
        if (s.kind == ScheduleKind::aware && level > 0) {
            // All channels are blended with the same weights.
            const double p = 1 + (J > 1 ? (level - 1.0) / (J - 1) : 1.0);
            const auto [ha, hb] = handover_weights(s.handover(level, J + 1, t), p);
            const float tf = static_cast<float>(t), haf = static_cast<float>(ha),
                        hbf = static_cast<float>(hb);
            // Each coefficient on its own: chunks shared among the cores, the same values.
            parallel_for(
                end - begin,
                [&](int64_t from, int64_t to) {
                    // In runs of at most kRun coefficients: their weights (A's, B's) on the stack.
                    // Plain pointers and locals, not the members and the closure's references,
                    // so that the loops vectorize.
                    constexpr size_t kRun = 1024;
                    float wa[kRun], wb[kRun];
                    const float t1 = tf, h1 = haf, h2 = hbf;
                    for (size_t first = begin + from; first < static_cast<size_t>(begin + to);
                         first += kRun) {
                        const size_t n = std::min(kRun, static_cast<size_t>(begin + to) - first);
                        const float* __restrict k = corresponding_.data() + first;
                        const float* __restrict la = local_a_.data() + first;
                        const float* __restrict lb = local_b_.data() + first;
                        const float* __restrict lab = local_ab_.data() + first;
                        for (size_t i = 0; i < n; ++i) {
                            const auto [x, y] =
                                aware_weights(k[i], la[i], lb[i], lab[i], t1, h1, h2);
                            wa[i] = x;
                            wb[i] = y;
                        }
                        for (size_t c = 0; c < channels; ++c) {
                            const float* a = coeff_a_[c].data() + first;
                            const float* b = coeff_b_[c].data() + first;
                            float* out = w[c].data() + first;
                            for (size_t i = 0; i < n; ++i) out[i] = wa[i] * a[i] + wb[i] * b[i];
                        }
                    }
                },
                32768);
            continue;
        }
        const float x = static_cast<float>(s.band_weight(level, J + 1, t));
        if (s.kind != ScheduleKind::sharp) {  // no energies: chunks shared among the cores
            parallel_for(
                end - begin,
                [&](int64_t from, int64_t to) {
                    const float xb = x, xa = 1 - x;  // locals, so that the loop vectorizes
                    const size_t first = begin + from, n = static_cast<size_t>(to - from);
                    for (size_t c = 0; c < channels; ++c) {
                        const float* __restrict a = coeff_a_[c].data() + first;
                        const float* __restrict b = coeff_b_[c].data() + first;
                        float* __restrict out = w[c].data() + first;
                        for (size_t i = 0; i < n; ++i) out[i] = xa * a[i] + xb * b[i];
                    }
                },
                32768);
            continue;
        }
        for (size_t c = 0; c < channels; ++c) {
            double energy = 0;
            for (int32_t i = begin; i < end; ++i) {
                w[c][i] = (1 - x) * coeff_a_[c][i] + x * coeff_b_[c][i];
                energy += double{w[c][i]} * w[c][i];
            }
            if (s.kind == ScheduleKind::sharp && level > 0 && energy > 0) {
                const double target =
                    (1 - x) * energy_a_[c][level - 1] + x * energy_b_[c][level - 1];
                const float gain = static_cast<float>(std::sqrt(target / energy));
                for (int32_t i = begin; i < end; ++i) w[c][i] *= gain;
            }
        }
    }
    return w;
}

Image Morph::with_residuals(const RenderPlan& plan, std::vector<std::span<const float>> planes,
                            double t, int side) const {
    const int J = levels();
    const Schedule& s = options_.schedule;
    const int channels = static_cast<int>(planes.size());
    if (channels != 3 && channels != 4) throw Error("morph: frames have 3 or 4 channels");
    const float x = static_cast<float>(s.band_weight(J, J + 1, t));
    Image out = make_image(plan.width, plan.height, channels, SampleFormat::u8);
    // Both: the residuals of A and B; weighted: by the two planes after the colour.
    const auto run = [&](const Image& ra, const Image& rb, float ka, float kb, bool both,
                         bool weighted) {
        const auto& maps_a = both || side == 0 ? quads_a_ : quads_b_;
        compose(plan, planes, {maps_a, quads_b_, ra, rb, ka, kb, both, weighted}, out);
    };
    if (side >= 0) {  // one endpoint alone
        const Image& residual = side == 0 ? residual_a_ : residual_b_;
        run(residual, residual, 1.0f, 0.0f, false, false);
        return out;
    }
    if (s.kind == ScheduleKind::aware) {
        // Each T_J sample's weights from the pixel agreement and the residuals' local energies at
        // its place in A (placed_, measured once), rendered with the frame.
        const auto [ha, hb] = handover_weights(s.handover(J + 1, J + 2, t), 2.0);
        const float tf = static_cast<float>(t), haf = static_cast<float>(ha),
                    hbf = static_cast<float>(hb);
        // placed_ holds the residuals' energies whenever the residual warp is on (the constructor).
        if (placed_.size() != 4) throw Error("morph: the residual band's measures are missing");
        const size_t n = placed_[0].size();
        // Every value is written below: no zeroing of 8 bytes a sample first.
        const std::unique_ptr<float[]> wa(new float[n]), wb(new float[n]);
        parallel_for(
            static_cast<int64_t>(n),
            [&](int64_t begin, int64_t end) {
                // Plain pointers and locals, so that the loop vectorizes.
                const float t1 = tf, h1 = haf, h2 = hbf;
                const float* __restrict k = placed_[0].data();
                const float* __restrict aa = placed_[1].data();
                const float* __restrict bb = placed_[2].data();
                const float* __restrict ab = placed_[3].data();
                float* __restrict xa = wa.get();
                float* __restrict xb = wb.get();
                for (int64_t i = begin; i < end; ++i) {
                    const auto [ka, kb] = aware_weights(k[i], aa[i], bb[i], ab[i], t1, h1, h2);
                    xa[i] = ka, xb[i] = kb;
                }
            },
            16384);
        planes.insert(planes.end(),
                      {std::span<const float>(wa.get(), n), std::span<const float>(wb.get(), n)});
        run(residual_a_, residual_b_, 0.0f, 0.0f, true, true);
        return out;
    }
    if (s.kind != ScheduleKind::sharp) {  // linear and bands: the finest band's weight
        run(residual_a_, residual_b_, 1 - x, x, true, false);
        return out;
    }
    // sharp: the residual is the finest band, rescaled like the others by energies over the
    // whole frame, so the warped residuals are kept for a second pass.
    const size_t n = out.planes[0].size();
    render_into(plan, planes, out);
    const Image warped_a = warped_through(plan, quads_a_, residual_a_);
    const Image warped_b = warped_through(plan, quads_b_, residual_b_);
    for (int c = 0; c < channels; ++c) {
        const std::vector<float>& ra = warped_a.planes[c];
        const std::vector<float>& rb = warped_b.planes[c];
        double ea = 0, eb = 0, e = 0;
        for (size_t i = 0; i < n; ++i) {
            const double blend = (1 - x) * ra[i] + x * rb[i];
            ea += double{ra[i]} * ra[i];
            eb += double{rb[i]} * rb[i];
            e += blend * blend;
        }
        const float gain = e > 0 ? static_cast<float>(std::sqrt(((1 - x) * ea + x * eb) / e)) : 1;
        for (size_t i = 0; i < n; ++i) out.planes[c][i] += gain * ((1 - x) * ra[i] + x * rb[i]);
    }
    return out;
}

std::vector<double> Morph::detail_energy(double t) const {
    const Planes w = blended(t);
    std::vector<double> e(levels(), 0.0);
    for (const auto& plane : w) {
        for (int j = 0; j < levels(); ++j) {
            for (int32_t i = hierarchy_.num_samples(j); i < hierarchy_.num_samples(j + 1); ++i) {
                e[j] += double{plane[i]} * plane[i];
            }
        }
    }
    return e;
}

Image Morph::render_at(Planes w, double t, bool preview, int side) const {
    const std::vector<Vec2> v = geometry(t);
    const Hierarchy& h = preview ? preview_ : hierarchy_;
    const int32_t n = h.num_samples(h.finest());
    if (preview) {
        for (auto& plane : w) plane.resize(n);  // nested numbering: T_J' is a prefix
    }
    inverse_transform(h, spans(w));  // patches shared among the cores
    const RenderPlan plan = plan_render(h, v, width_, height_, width_, height_);
    std::vector<std::span<const float>> in(w.begin(), w.end());
    if (options_.residual && !preview) return with_residuals(plan, std::move(in), t, side);
    return render(plan, in, SampleFormat::u8);
}

Image Morph::frame(double t, const FrameOptions& options) const {
    return render_at(blended(t), t, options.preview, -1);
}

Image Morph::warped(double t, int side) const {
    if (!(t >= 0 && t <= 1)) throw Error(str("morph: t = ", t, " is outside [0, 1]"));
    return render_at(side == 0 ? coeff_a_ : coeff_b_, t, false, side == 0 ? 0 : 1);
}

}  // namespace tesswave::morph
