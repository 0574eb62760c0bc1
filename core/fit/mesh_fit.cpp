#include "core/fit/mesh_fit.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "core/fit/fit_start.h"
#include "core/fit/fit_terms.h"
#include "core/math/error.h"
#include "core/math/parametrization.h"
#include "core/math/strings.h"
#include "core/math/validate.h"

namespace tesswave {
namespace {

using fit_detail::Frame, fit_detail::make_frame, fit_detail::initial_vertices,
    fit_detail::initial_transforms;
using fit_detail::kLeft, fit_detail::kRight, fit_detail::kTop, fit_detail::kBottom;
using fit_detail::LinearCost, fit_detail::EdgeRigidity, fit_detail::CornerBarrier,
    fit_detail::EdgeBarrier;

constexpr int kMaxIterations = 100'000;

bool finite(Vec2 p) { return std::isfinite(p.x) && std::isfinite(p.y); }

// The T1 quads of a mesh, straight from its faces (the numbering of hierarchy.h's refine()).
std::vector<Quad> t1_quads_of(const Mesh& mesh, std::span<const Vec2> positions) {
    std::vector<Quad> quads(mesh.face_corners.size());
    for (int f = 0; f < mesh.num_faces(); ++f) {
        auto c = mesh.face(f);
        const size_t n = c.size();
        Vec2 centroid{};
        for (int32_t v : c) centroid = centroid + positions[v];
        centroid = (1.0 / n) * centroid;
        for (size_t s = 0; s < n; ++s) {
            const Vec2 here = positions[c[s]];
            const Vec2 next = positions[c[(s + 1) % n]], prev = positions[c[(s + n - 1) % n]];
            quads[mesh.face_offsets[f] + s] = {here, lerp(here, next, 0.5), centroid,
                                               lerp(prev, here, 0.5)};
        }
    }
    return quads;
}

// P_k as weights on the corners of the pin's face: the bilinear weights of the quad's corners,
// with each midpoint split over its edge's ends and the centroid over all n corners.
void pin_weights(const Mesh& mesh, const PinnedPoint& pin, std::vector<double>& w) {
    if (pin.face < 0 || pin.face >= mesh.num_faces() || pin.quad < mesh.face_offsets[pin.face] ||
        pin.quad >= mesh.face_offsets[pin.face + 1] || !std::isfinite(pin.u) ||
        !std::isfinite(pin.v)) {
        throw Error(str("pinned point: face ", pin.face, ", quad ", pin.quad,
                        " is not a T1 quad of the mesh"));
    }
    const int n = mesh.face_offsets[pin.face + 1] - mesh.face_offsets[pin.face];
    const int s = pin.quad - mesh.face_offsets[pin.face];
    const double u = pin.u, v = pin.v;
    w.assign(n, u * v / n);
    w[s] += (1 - u) * (1 - v) + 0.5 * u * (1 - v) + 0.5 * (1 - u) * v;
    w[(s + 1) % n] += 0.5 * u * (1 - v);
    w[(s + n - 1) % n] += 0.5 * (1 - u) * v;
}

// Reports progress, and stops the solver once a successful step is below the step tolerance.
class IterationWatch : public ceres::IterationCallback {
  public:
    explicit IterationWatch(const MeshFitOptions& options) : options_(options) {}
    ceres::CallbackReturnType operator()(const ceres::IterationSummary& summary) override {
        if (options_.progress) {
            options_.progress(
                std::min(1.0, static_cast<double>(summary.iteration) / options_.max_iterations),
                "fitting");
        }
        if (summary.iteration > 0 && summary.step_is_successful &&
            summary.step_norm < options_.step_tolerance) {
            return ceres::SOLVER_TERMINATE_SUCCESSFULLY;
        }
        return ceres::SOLVER_CONTINUE;
    }

  private:
    const MeshFitOptions& options_;
};

void check_inputs(const Mesh& mesh_a, std::span<const Vec2> points_a,
                  std::span<const Vec2> points_b, double width_b, double height_b,
                  const MeshFitOptions& o) {
    require_valid(mesh_a, "mesh fit: mesh A");
    if (!(width_b >= kMinDomain && height_b >= kMinDomain && width_b <= kMaxDomain &&
          height_b <= kMaxDomain)) {
        throw Error(str("mesh fit: image B's domain ", width_b, " x ", height_b,
                        " is outside the supported ", kMinDomain, " .. ", kMaxDomain,
                        " pixels a side"));
    }
    if (points_a.size() != points_b.size()) {
        throw Error(str("mesh fit: ", points_a.size(), " points on A but ", points_b.size(),
                        " on B; correspondences come in pairs"));
    }
    if (points_a.size() < 3) {
        throw Error(str("mesh fit: ", points_a.size(), " correspondences, at least 3 needed"));
    }
    for (size_t k = 0; k < points_a.size(); ++k) {
        if (!finite(points_a[k]) || !finite(points_b[k])) {
            throw Error(str("mesh fit: correspondence ", k, " has a non-finite coordinate"));
        }
    }
    auto bad = [](double w) { return !(std::isfinite(w) && w >= 0); };
    if (bad(o.rigidity_weight) || bad(o.smoothness_weight) || bad(o.temporal_weight)) {
        throw Error("mesh fit: weights must be finite and non-negative");
    }
    if (!(o.robust_scale > 0 && std::isfinite(o.robust_scale)) ||
        !(o.outlier_factor > 0 && std::isfinite(o.outlier_factor))) {
        throw Error("mesh fit: robust_scale and outlier_factor must be finite and positive");
    }
    if (!(o.min_corner_sine > 0 && o.min_corner_sine < 1) ||
        !(o.min_edge_ratio > 0 && o.min_edge_ratio < 1)) {
        throw Error("mesh fit: min_corner_sine and min_edge_ratio must be in (0, 1)");
    }
    if (o.max_iterations < 1 || o.max_iterations > kMaxIterations) {
        throw Error(str("mesh fit: max_iterations must be in 1..", kMaxIterations));
    }
    if (!(o.step_tolerance >= 0 && o.step_tolerance <= 1e3)) {
        throw Error(str("mesh fit: step_tolerance ", o.step_tolerance, " is not in [0, 1000] px"));
    }
    if (o.temporal_weight > 0 && o.previous.empty()) {
        throw Error("mesh fit: temporal_weight needs the previous frame's vertices");
    }
    if (!o.previous.empty() && o.previous.size() != mesh_a.vertices.size()) {
        throw Error(str("mesh fit: ", o.previous.size(), " previous vertices for a mesh of ",
                        mesh_a.vertices.size()));
    }
    if (!std::all_of(o.previous.begin(), o.previous.end(), finite)) {
        throw Error("mesh fit: a previous vertex has a non-finite coordinate");
    }
}

struct FitProblem {
    const Mesh& mesh;
    const Frame& frame;
    const MeshFitOptions& options;
    std::vector<double> x;  // vertex blocks, 2 doubles each
    std::vector<double> s;  // per-face transform blocks, 2 doubles each (ARAP uses the first)
    ceres::CauchyLoss cauchy;
    ceres::SubsetManifold hold_x{2, {0}}, hold_y{2, {1}};
    ceres::Problem problem;
    ceres::Solver::Summary summary;

    FitProblem(const Mesh& m, const Frame& f, const MeshFitOptions& o)
        : mesh(m), frame(f), options(o), cauchy(o.robust_scale), problem(problem_options()) {}

    static ceres::Problem::Options problem_options() {
        ceres::Problem::Options p;
        p.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
        p.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
        return p;
    }
    double* vertex(int32_t v) { return &x[2 * v]; }
    std::vector<double*> face_blocks(int f) {
        std::vector<double*> blocks;
        for (int32_t v : mesh.face(f)) blocks.push_back(vertex(v));
        return blocks;
    }

    void add_vertices() {
        for (int v = 0; v < mesh.num_vertices(); ++v) {
            const int sides = frame.sides[v];
            const bool across_x = sides & (kLeft | kRight), across_y = sides & (kTop | kBottom);
            problem.AddParameterBlock(vertex(v), 2);
            if (across_x && across_y) {
                problem.SetParameterBlockConstant(vertex(v));
            } else if (across_x) {
                problem.SetManifold(vertex(v), &hold_x);
            } else if (across_y) {
                problem.SetManifold(vertex(v), &hold_y);
            }
        }
    }

    void add_data(const std::vector<PinnedPoint>& pins, std::span<const Vec2> points_b) {
        std::vector<double> w;
        for (size_t k = 0; k < pins.size(); ++k) {
            pin_weights(mesh, pins[k], w);
            problem.AddResidualBlock(new LinearCost(w, points_b[k]), &cauchy,
                                     face_blocks(pins[k].face));
        }
    }

    template <Rigidity kind>
    void add_rigidity() {
        constexpr int size = kind == Rigidity::as_rigid ? 1 : 2;
        double mean = 0;
        for (int f = 0; f < mesh.num_faces(); ++f) {
            auto c = mesh.face(f);
            for (size_t i = 0; i < c.size(); ++i) {
                mean += norm(frame.reference[c[(i + 1) % c.size()]] - frame.reference[c[i]]);
            }
        }
        mean /= mesh.face_corners.size();
        for (int f = 0; f < mesh.num_faces(); ++f) {
            auto c = mesh.face(f);
            for (size_t i = 0; i < c.size(); ++i) {
                const int32_t p = c[i], q = c[(i + 1) % c.size()];
                const Vec2 edge = frame.reference[q] - frame.reference[p];
                const double weight = std::sqrt(options.rigidity_weight) * mean / norm(edge);
                problem.AddResidualBlock(
                    new ceres::AutoDiffCostFunction<EdgeRigidity<kind>, 2, 2, 2, size>(
                        new EdgeRigidity<kind>{edge, weight}),
                    nullptr, vertex(p), vertex(q), &s[2 * f]);
            }
        }
    }

    void add_smoothness(const MeshEdges& edges) {
        std::vector<std::vector<int32_t>> neighbours(mesh.num_vertices());
        for (auto [p, q] : edges.vertices) neighbours[p].push_back(q), neighbours[q].push_back(p);
        const double weight = std::sqrt(options.smoothness_weight);
        for (int v = 0; v < mesh.num_vertices(); ++v) {
            const auto& nb = neighbours[v];
            std::vector<double> w(nb.size() + 1, -weight / nb.size());
            std::vector<double*> blocks{vertex(v)};
            Vec2 lap = frame.reference[v];
            for (int32_t q : nb) {
                blocks.push_back(vertex(q));
                lap = lap - (1.0 / nb.size()) * frame.reference[q];
            }
            w[0] = weight;
            problem.AddResidualBlock(new LinearCost(std::move(w), weight * lap), nullptr, blocks);
        }
    }

    void add_temporal() {
        const double weight = std::sqrt(options.temporal_weight);
        for (int v = 0; v < mesh.num_vertices(); ++v) {
            problem.AddResidualBlock(new LinearCost({weight}, weight * options.previous[v]),
                                     nullptr, vertex(v));
        }
    }

    void add_barriers(const MeshEdges& edges) {
        for (auto [p, q] : edges.vertices) {
            problem.AddResidualBlock(
                new ceres::AutoDiffCostFunction<EdgeBarrier, 1, 2, 2>(new EdgeBarrier{
                    norm(frame.reference[q] - frame.reference[p]), options.min_edge_ratio}),
                nullptr, vertex(p), vertex(q));
        }
        for (int f = 0; f < mesh.num_faces(); ++f) {
            auto c = mesh.face(f);
            const size_t n = c.size();
            for (size_t i = 0; i < n; ++i) {
                const int32_t p = c[(i + n - 1) % n], h = c[i], q = c[(i + 1) % n];
                const Vec2 a = frame.reference[h] - frame.reference[p];
                const Vec2 b = frame.reference[q] - frame.reference[h];
                const double sine = cross(a, b) / (norm(a) * norm(b));
                const double margin = std::min(options.min_corner_sine, 0.5 * sine);
                problem.AddResidualBlock(new ceres::AutoDiffCostFunction<CornerBarrier, 1, 2, 2, 2>(
                                             new CornerBarrier{margin}),
                                         nullptr, vertex(p), vertex(h), vertex(q));
            }
        }
    }
};

// Point location on the T1 quads; a quad's face by binary search in the face offsets.
std::vector<std::optional<PinnedPoint>> locate(const Mesh& mesh, std::span<const Vec2> positions,
                                               std::span<const Vec2> points) {
    QuadLocator locator(t1_quads_of(mesh, positions), mesh.width, mesh.height);
    std::vector<std::optional<PinnedPoint>> pins(points.size());
    for (size_t k = 0; k < points.size(); ++k) {
        if (const auto hit = locator.locate(points[k])) {
            const auto face =
                std::upper_bound(mesh.face_offsets.begin(), mesh.face_offsets.end(), hit->quad) -
                mesh.face_offsets.begin() - 1;
            pins[k] = PinnedPoint{static_cast<int32_t>(face), hit->quad, hit->uv.u, hit->uv.v};
        }
    }
    return pins;
}

std::vector<PinnedPoint> pin_all(const Mesh& mesh, std::span<const Vec2> points) {
    const auto located = locate(mesh, mesh.vertices, points);
    std::vector<PinnedPoint> pins(points.size());
    for (size_t k = 0; k < points.size(); ++k) {
        if (!located[k]) {
            throw Error(str("mesh fit: point ", k, " (", points[k].x, ", ", points[k].y,
                            ") lies outside image A's domain [0,", mesh.width, "]x[0,", mesh.height,
                            "]"));
        }
        pins[k] = *located[k];
    }
    return pins;
}

void solve(FitProblem& fit) {
    ceres::Solver::Options solver;
    solver.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
    solver.num_threads = 1;
    solver.max_num_iterations = fit.options.max_iterations;
    solver.function_tolerance = 1e-10;
    solver.parameter_tolerance = 1e-10;
    solver.logging_type = ceres::SILENT;
    solver.minimizer_progress_to_stdout = false;
    IterationWatch watch(fit.options);
    if (fit.options.progress || fit.options.step_tolerance > 0) solver.callbacks.push_back(&watch);
    ceres::Solve(solver, &fit.problem, &fit.summary);
    if (fit.summary.termination_type == ceres::FAILURE ||
        fit.summary.termination_type == ceres::USER_FAILURE) {
        throw Error(str("mesh fit: the solver failed: ", fit.summary.message));
    }
}

// The fitted mesh, checked, and its residuals.
MeshFitResult finish(const FitProblem& fit, const std::vector<PinnedPoint>& pins,
                     std::span<const Vec2> points_b) {
    Mesh b = fit.mesh;
    b.width = fit.frame.width, b.height = fit.frame.height;
    for (int v = 0; v < b.num_vertices(); ++v) b.vertices[v] = {fit.x[2 * v], fit.x[2 * v + 1]};
    MeshFitResult result;
    const ValidationReport report = validate(b, {.max_problems = 1});
    if (!report.ok()) {
        result.failure = "no valid mesh fits: " + report.problems.front();
        return result;
    }
    result.iterations = fit.summary.num_successful_steps + fit.summary.num_unsuccessful_steps;
    const double limit = fit.options.outlier_factor * fit.options.robust_scale;
    double sum2 = 0;
    for (size_t k = 0; k < pins.size(); ++k) {
        const double r = norm(pinned_position(b, b.vertices, pins[k]) - points_b[k]);
        result.residuals.push_back(r);
        if (r > limit) {
            ++result.outliers;
        } else {
            ++result.inliers, sum2 += r * r, result.max = std::max(result.max, r);
        }
    }
    if (result.inliers < 3) {
        result.failure = str("no valid mesh fits: only ", result.inliers, " of ", pins.size(),
                             " correspondences within ", limit, " px of the fitted mesh");
        return result;
    }
    result.rms = std::sqrt(sum2 / result.inliers);
    result.vertices = std::move(b.vertices);
    return result;
}

}  // namespace

std::vector<std::optional<PinnedPoint>> pin_points(const Mesh& mesh, std::span<const Vec2> points) {
    return pin_points(mesh, mesh.vertices, points);
}

std::vector<std::optional<PinnedPoint>> pin_points(const Mesh& mesh,
                                                   std::span<const Vec2> positions,
                                                   std::span<const Vec2> points) {
    require_valid(mesh, positions, "pin points");
    return locate(mesh, positions, points);
}

Vec2 pinned_position(const Mesh& mesh, std::span<const Vec2> vertices, const PinnedPoint& pin) {
    if (vertices.size() != mesh.vertices.size()) {
        throw Error(str("pinned point: ", vertices.size(), " vertices for a mesh of ",
                        mesh.vertices.size()));
    }
    std::vector<double> w;
    pin_weights(mesh, pin, w);
    auto corners = mesh.face(pin.face);
    Vec2 p{};
    for (size_t k = 0; k < corners.size(); ++k) p = p + w[k] * vertices[corners[k]];
    return p;
}

MeshFitResult fit_mesh(const Mesh& mesh_a, std::span<const Vec2> points_a,
                       std::span<const Vec2> points_b, double width_b, double height_b,
                       const MeshFitOptions& options) {
    check_inputs(mesh_a, points_a, points_b, width_b, height_b, options);
    const std::vector<PinnedPoint> pins = pin_all(mesh_a, points_a);
    if (options.progress) options.progress(0.0, "fitting");
    const Frame frame = make_frame(mesh_a, width_b, height_b);
    const std::vector<Vec2> start = initial_vertices(mesh_a, frame, points_a, points_b, options);

    FitProblem fit(mesh_a, frame, options);
    for (const Vec2& p : start) fit.x.insert(fit.x.end(), {p.x, p.y});
    fit.s = initial_transforms(mesh_a, frame, start, options.rigidity);
    fit.add_vertices();
    fit.add_data(pins, points_b);
    if (options.rigidity_weight > 0) {
        options.rigidity == Rigidity::as_rigid ? fit.add_rigidity<Rigidity::as_rigid>()
                                               : fit.add_rigidity<Rigidity::as_similar>();
    }
    const MeshEdges edges = build_edges(mesh_a);
    if (options.smoothness_weight > 0) fit.add_smoothness(edges);
    if (options.temporal_weight > 0) fit.add_temporal();
    fit.add_barriers(edges);
    solve(fit);
    MeshFitResult result = finish(fit, pins, points_b);
    if (options.progress) options.progress(1.0, "done");
    return result;
}

}  // namespace tesswave
