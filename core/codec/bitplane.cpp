#include "core/codec/bitplane.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <type_traits>

#include "core/codec/range_coder.h"
#include "core/math/error.h"
#include "core/math/strings.h"

namespace tesswave {
namespace {

// Coefficient state bits; kParent: a parent is significant.
constexpr uint8_t kSignificant = 1, kNegative = 2, kRefined = 4, kParent = 8;
constexpr int kRun = 4;  // isolated coefficients coded together in run mode
// Zero blocks: this many isolated coefficients, one decision each (or none, when known) before
// their smaller blocks and runs (BitplaneOptions::blocks).
constexpr int kBlock[2] = {64, 16};
static_assert(kBlock[0] % kBlock[1] == 0 && kBlock[1] % kRun == 0 && kBlock[0] <= 64);
// Bands of fewer coefficients code runs only: in them the blocks' decisions cost more than they
// save (with blocks in every band, at the same rate: up to 0.033 dB lost on a 176x144 clip and
// 0.055 dB on the tests' 128x96 image).
constexpr int32_t kBlockBand = 4096;
constexpr uint8_t kNone = 32;  // `known` of a coefficient no plane of which was coded
// The probability models of one band and channel class.
struct BandModels {
    // [a parent significant][significant primary neighbours, capped at 2][others, capped at 2]
    BitModel significance[2][3][3];
    BitModel sign[3];               // neighbour signs: net negative, balanced, net positive
    BitModel refinement[3];         // first refinement without / with significant neighbours; later
    BitModel run, run_position[3];  // run mode: any significant; position of the first

    void settle() {
        for (auto& a : significance) {
            for (auto& b : a) {
                for (BitModel& m : b) m = BitModel::settled();
            }
        }
        for (BitModel* group : {sign, refinement, run_position}) {
            for (int i = 0; i < 3; ++i) group[i] = BitModel::settled();
        }
        run = BitModel::settled();
    }
};

// The zero blocks' models of one channel class, shared by all bands (short streams, a temporal
// band's or a small frame's, pay for every model they learn): block[i][j] whether a block of
// kBlock[i] holds a significant coefficient, j = 1 inside a larger block that does; run: whether
// a run inside a block of kBlock[1] that does holds one.
struct BlockModels {
    BitModel block[2][2], run;
    static BlockModels settled() {
        const BitModel m = BitModel::settled();
        return {{{m, m}, {m, m}}, m};
    }
};

int channel_class(int channel) { return channel == 0 ? 0 : channel < 3 ? 1 : 2; }

// n planes of `size` values v, each filled in place (copies of one filled plane would read it n
// times over).
template <class T>
std::vector<std::vector<T>> filled(size_t n, size_t size, T v) {
    std::vector<std::vector<T>> out(n);
    for (auto& plane : out) plane.assign(size, v);
    return out;
}

class EncodeSide {
  public:
    explicit EncodeSide(size_t max_bytes) : limit_(max_bytes) {}
    int bit(BitModel& model, int value) {
        encoder_.encode(model, value);
        return value;
    }
    bool stopped() const { return encoder_.size_if_finished() > limit_; }
    size_t size() const { return encoder_.size_if_finished(); }
    std::vector<uint8_t> finish() { return encoder_.finish(); }

  private:
    RangeEncoder encoder_;
    size_t limit_;
};

class DecodeSide {
  public:
    explicit DecodeSide(std::span<const uint8_t> stream) : decoder_(stream) {}
    int bit(BitModel& model, int) { return decoder_.decode(model); }
    bool stopped() const { return decoder_.exhausted(); }

  private:
    RangeDecoder decoder_;
};

// One traversal for both sides: the encoder reads `value`, the decoder fills it. Returns false
// once the side stopped (budget spent, or input exhausted: the last decision is then void).
template <class Side>
class Traversal {
  public:
    // The coefficients: read by the encoder from its input, filled in by the decoder.
    using Value = std::conditional_t<std::is_same_v<Side, DecodeSide>, int32_t, const int32_t>;

    Traversal(const CodingLayout& layout, const PlaneCounts& planes, const BitplaneOptions& options,
              std::vector<std::span<Value>> value, std::vector<std::vector<uint8_t>>& known,
              Side& side)
        : layout_(layout),
          planes_(planes),
          options_(options),
          value_(std::move(value)),
          known_(known),
          side_(side),
          state_(filled<uint8_t>(value_.size(), layout.size, 0)),
          near_(filled<uint8_t>(value_.size(), layout.size, 0)),
          candidates_(filled<uint64_t>(value_.size(), (layout.size + 63) / 64, 0)),
          significant_(filled<uint64_t>(value_.size(), (layout.size + 63) / 64, 0)),
          swept_(value_.size(), std::vector<uint8_t>(layout.bands.size(), kNone)),
          models_(layout.bands.size() * 4),
          grid_(!layout.grid_bands.empty()) {
        if (!options.fast_start) {
            for (BandModels& m : models_) m.settle();
            blocks_.fill(BlockModels::settled());
        }
        // Positions of the coefficient ids, unless the order is the identity (the mesh's) or
        // the relations are computed (a grid's, whose positions are computed too).
        bool identity = true;
        for (int32_t k = 0; k < layout.size && identity && !grid_; ++k) {
            identity = layout.order[k] == k;
        }
        if (!identity) {
            position_.resize(layout.size);
            for (int32_t k = 0; k < layout.size; ++k) position_[layout.order[k]] = k;
        }
    }

    bool run() {
        const int bands = static_cast<int>(layout_.bands.size());
        int sweeps = 0;
        for (size_t c = 0; c < planes_.size(); ++c) {
            for (int b = 0; b < bands; ++b) sweeps = std::max(sweeps, planes_[c][b] + shift(b));
        }
        std::vector<size_t>* ends = nullptr;
        if constexpr (std::is_same_v<Side, EncodeSide>) ends = options_.pass_ends;
        if (ends) ends->assign(3 * static_cast<size_t>(sweeps), SIZE_MAX);
        // Each pass runs over all bands before the next: significance next to significant
        // coefficients gains the most per bit, then refinement, then the isolated rest.
        for (int t = sweeps - 1; t >= 0; --t) {
            for (int pass = 0; pass < 3; ++pass) {
                for (int b = 0; b < bands; ++b) {
                    const int p = t - shift(b);
                    for (size_t c = 0; c < planes_.size(); ++c) {
                        if (p < 0 || p >= planes_[c][b]) continue;
                        if (!run_pass(pass, static_cast<int>(c), b, p)) {
                            settle_known();
                            return false;
                        }
                    }
                }
                if constexpr (std::is_same_v<Side, EncodeSide>) {
                    if (ends) (*ends)[3 * static_cast<size_t>(t) + pass] = side_.size();
                }
            }
        }
        settle_known();
        return true;
    }

  private:
    // Bands of one orientation (point type) share their models: per-band models learn too slowly
    // at low rates (measured: +0.1 dB at 0.25 bpp on Kodak with the 9/7).
    int model_group(int b) const {
        switch (layout_.bands[b].type) {
            case 'v':
            case 'L':
                return 0;
            case 'e':
            case 'H':
                return 1;
            case 'f':
            case 'V':
                return 2;
            default:
                return 3;
        }
    }
    int shift(int b) const { return options_.shifts.empty() ? 0 : options_.shifts[b]; }

    // 3 a + b for a significant primary and b other significant neighbours (each capped at 2),
    // from the counts kept in near (primary in the low nibble, the others in the high one).
    static int significant_neighbours(const uint8_t* near, int32_t id) {
        const int n = near[id];
        return 3 * std::min(n & 15, 2) + std::min(n >> 4, 2);
    }
    // Listed relations: visit(id, position, primary) for each neighbour of the coefficient at
    // position k.
    template <class Visit>
    void for_each_neighbour(int32_t k, Visit&& visit) const {
        const int32_t begin = layout_.nb_offsets[k], split = begin + layout_.nb_primary[k];
        for (int32_t i = begin; i < layout_.nb_offsets[k + 1]; ++i) {
            visit(layout_.nb[i], position(layout_.nb[i]), i < split);
        }
    }

    // Grid layouts: where the coefficient at position k of the band being coded sits in it.
    struct GridSpot {
        int32_t x, y, id, k;
    };
    GridSpot grid_spot(int32_t k) const {
        const GridBand& g = layout_.grid_bands[band_];
        const int32_t r = k - layout_.bands[band_].begin, y = r / g.width, x = r - y * g.width;
        return {x, y, (g.y0 + y) * layout_.grid_width + g.x0 + x, k};
    }
    // visit(id, position, add) for the 8 around `at` inside its band, where add is what the
    // neighbour's count gains (1 primary, 16 other).
    template <class Visit>
    void grid_neighbours(const GridSpot& at, Visit&& visit) const {
        const GridBand& g = layout_.grid_bands[band_];
        const GridStar& s = star_;
        if (at.x > 0 && at.y > 0 && at.x + 1 < g.width && at.y + 1 < g.height) {
            for (int i = 0; i < 8; ++i) visit(at.id + s.id[i], at.k + s.position[i], s.add[i]);
            return;
        }
        for (int i = 0; i < 8; ++i) {
            const int32_t x = at.x + s.dx[i], y = at.y + s.dy[i];
            if (x < 0 || y < 0 || x >= g.width || y >= g.height) continue;
            visit(at.id + s.id[i], at.k + s.position[i], s.add[i]);
        }
    }
    // visit(id, position) for each child of `at`. A coefficient (x, y) of the finer band has the
    // parent (min(x / 2, w - 1), min(y / 2, h - 1)) in this w x h band, so the children of its
    // last column or row reach to the end of the finer band.
    template <class Visit>
    void grid_children(const GridSpot& at, Visit&& visit) const {
        const int32_t cb = layout_.grid_child_band[band_];
        if (cb < 0) return;
        const GridBand& g = layout_.grid_bands[band_];
        const GridBand& f = layout_.grid_bands[cb];
        const int32_t x1 = at.x + 1 == g.width ? f.width : std::min(2 * at.x + 2, f.width);
        const int32_t y1 = at.y + 1 == g.height ? f.height : std::min(2 * at.y + 2, f.height);
        for (int32_t fy = 2 * at.y; fy < y1; ++fy) {
            for (int32_t fx = 2 * at.x; fx < x1; ++fx) {
                visit((f.y0 + fy) * layout_.grid_width + f.x0 + fx,
                      layout_.bands[cb].begin + fy * f.width + fx);
            }
        }
    }
    // The band's 8 neighbour offsets (as ids and as positions) and what each adds to counts.
    void set_grid_star() {
        const GridBand& g = layout_.grid_bands[band_];
        int i = 0;
        for (int dy = -1; dy <= 1; ++dy) {
            for (int dx = -1; dx <= 1; ++dx) {
                if (dx == 0 && dy == 0) continue;
                star_.dx[i] = static_cast<int8_t>(dx);
                star_.dy[i] = static_cast<int8_t>(dy);
                star_.id[i] = dy * layout_.grid_width + dx;
                star_.position[i] = dy * g.width + dx;
                star_.add[i] = grid_primary(g.type, dx, dy) ? 1 : 16;
                ++i;
            }
        }
    }

    // A coefficient became significant: its neighbours count it (the relation is symmetric, and
    // primary on both sides: coding_layout_test checks the lists, and on a computed grid
    // grid_primary(t, dx, dy) equals grid_primary(t, -dx, -dy)).
    // Each neighbour not yet significant becomes a candidate of pass 0.
    void count_significant(uint8_t* near, const uint8_t* state, uint64_t* candidates,
                           int32_t k) const {
        for_each_neighbour(k, [&](int32_t id, int32_t position, bool primary) {
            uint8_t& n = near[id];
            if (primary) {
                if ((n & 15) < 15) ++n;
            } else if ((n >> 4) < 15) {
                n += 16;
            }
            if (!(state[id] & kSignificant)) set_bit(candidates, position);
        });
    }
    // Listed relations only: a computed grid's positions come from its bands' rectangles.
    int32_t position(int32_t id) const { return position_.empty() ? id : position_[id]; }
    static void set_bit(uint64_t* bits, int32_t k) { bits[k >> 6] |= uint64_t{1} << (k & 63); }
    static void clear_bit(uint64_t* bits, int32_t k) { bits[k >> 6] &= ~(uint64_t{1} << (k & 63)); }
    // The set positions of `bits` in [begin, end), in increasing order, each passed to visit (which
    // returns false to stop); bits that visit sets ahead of the current position are seen too.
    template <class Visit>
    static bool for_each_set(const uint64_t* bits, int32_t begin, int32_t end, Visit&& visit) {
        int32_t k = begin;
        while (k < end) {
            const uint64_t word = bits[k >> 6] >> (k & 63);
            if (word == 0) {
                k = ((k >> 6) + 1) << 6;
                continue;
            }
            k += std::countr_zero(word);
            if (k >= end) break;
            if (!visit(k)) return false;
            ++k;
        }
        return true;
    }
    static int parent_significant(const uint8_t* state, int32_t id) {
        return (state[id] & kParent) ? 1 : 0;
    }
    int sign_context(const uint8_t* state, int32_t k) const {
        int net = 0;
        for_each_neighbour(k, [&](int32_t id, int32_t, bool) {
            const uint8_t s = state[id];
            if (s & kSignificant) net += (s & kNegative) ? -1 : 1;
        });
        return net < 0 ? 0 : net == 0 ? 1 : 2;
    }

    // Codes bit p of a coefficient not yet significant; false when the side stopped.
    bool significance(BandModels& m, uint8_t* state, int32_t k, int32_t id, int p, int nb, int pa,
                      Value& v, uint8_t& known) {
        const int bit = side_.bit(m.significance[pa][nb / 3][nb % 3], (std::abs(v) >> p) & 1);
        if (side_.stopped()) return false;
        // Known only once settled: a stream cut before the sign leaves the coefficient unknown.
        if (bit && !become_significant(m, state, k, id, p, v)) return false;
        known = static_cast<uint8_t>(p);
        return true;
    }

    // Codes the sign of a coefficient whose bit p is its first 1, and records it significant.
    bool become_significant(BandModels& m, uint8_t* state, int32_t k, int32_t id, int p, Value& v) {
        ++found_;
        if (grid_) return become_significant_on_grid(m, state, k, p, v);
        const int negative = side_.bit(m.sign[sign_context(state, k)], v < 0);
        if (side_.stopped()) return false;
        state[id] |= kSignificant | (negative ? kNegative : 0);
        uint64_t* candidates = candidates_[c_].data();
        clear_bit(candidates, k);
        set_bit(significant_[c_].data(), k);
        count_significant(near_[c_].data(), state, candidates, k);
        for (int32_t i = layout_.ch_offsets[id]; i < layout_.ch_offsets[id + 1]; ++i) {
            const int32_t child = layout_.ch[i];
            state[child] |= kParent;
            if (!(state[child] & kSignificant)) set_bit(candidates, position(child));
        }
        if constexpr (std::is_same_v<Side, DecodeSide>) v = negative ? -(1 << p) : 1 << p;
        return true;
    }
    // The same on a grid, its place in the band found once and its neighbours' updates without
    // branches (at most 8 neighbours: the counts never reach their cap of 15).
    bool become_significant_on_grid(BandModels& m, uint8_t* state, int32_t k, int p, Value& v) {
        const GridSpot at = grid_spot(k);
        int net = 0;
        grid_neighbours(at, [&](int32_t n, int32_t, uint8_t) {
            const int s = state[n];
            net += (s & kSignificant) * (1 - (s & kNegative));  // +1, -1, or 0 if not significant
        });
        const int negative = side_.bit(m.sign[net < 0 ? 0 : net == 0 ? 1 : 2], v < 0);
        if (side_.stopped()) return false;
        state[at.id] |= kSignificant | (negative ? kNegative : 0);
        uint64_t* candidates = candidates_[c_].data();
        uint8_t* near = near_[c_].data();
        clear_bit(candidates, k);
        set_bit(significant_[c_].data(), k);
        const auto mark = [&](int32_t n, int32_t position) {
            candidates[position >> 6] |= uint64_t{!(state[n] & kSignificant)} << (position & 63);
        };
        grid_neighbours(at, [&](int32_t n, int32_t position, uint8_t add) {
            near[n] = static_cast<uint8_t>(near[n] + add);
            mark(n, position);
        });
        grid_children(at, [&](int32_t child, int32_t position) {
            state[child] |= kParent;
            mark(child, position);
        });
        if constexpr (std::is_same_v<Side, DecodeSide>) v = negative ? -(1 << p) : 1 << p;
        return true;
    }

    // kRun coefficients from position k, none significant, none visited in this plane, none with
    // a significant neighbour or parent: none is a candidate or significant (pass 2 visits them
    // in order, and the coefficients ahead of it that passes 0 and 1 visited are one or the other).
    bool isolated_run(int c, int32_t k) const { return isolated(c, k, kRun); }
    // The same for n coefficients from k (n at most 64).
    bool isolated(int c, int32_t k, int n) const {
        const uint64_t* cand = candidates_[c].data();
        const uint64_t* sig = significant_[c].data();
        const int32_t w = k >> 6, b = k & 63;
        uint64_t busy = (cand[w] | sig[w]) >> b;
        if (b + n > 64) busy |= (cand[w + 1] | sig[w + 1]) << (64 - b);
        return (n == 64 ? busy : busy & ((uint64_t{1} << n) - 1)) == 0;
    }

    // Whether bit p of any of the n coefficients from position k is set (the encoder's zero
    // block decision).
    bool block_any(const Value* value, int32_t k, int n, int p) const {
        uint32_t any = 0;
        for (int i = 0; i < n; ++i)
            any |= static_cast<uint32_t>(std::abs(value[layout_.order[k + i]]));
        return (any >> p) & 1;
    }

    // Run mode (EBCOT's): one decision for kRun isolated coefficients; when one of them turns
    // significant, the position of the first (2 bits) and its sign. Returns how many
    // coefficients it settled (0 when the side stopped; run_known_ then tells how many at k were
    // found insignificant before the stop).
    // `forced`: the run is known to hold a significant coefficient (the last run of a zero block
    // that has one, after its other runs had none), so that decision is not coded. `in_block`:
    // the run lies in a block of kBlock[1] that holds one, and takes its own model.
    int run(BandModels& m, uint8_t* state, Value* value, uint8_t* known, int32_t k, int p,
            bool forced, bool in_block) {
        run_known_ = 0;
        int first = kRun;
        if constexpr (std::is_same_v<Side, EncodeSide>) {
            for (int i = kRun - 1; i >= 0; --i) {
                if ((std::abs(value[layout_.order[k + i]]) >> p) & 1) first = i;
            }
        }
        BitModel& model = in_block ? blocks_[channel_class(c_)].run : m.run;
        const int any = forced ? 1 : side_.bit(model, first < kRun);
        if (side_.stopped()) return 0;
        if (any) {
            const int hi = side_.bit(m.run_position[0], first >> 1);
            const int lo = side_.bit(m.run_position[1 + hi], first & 1);
            if (side_.stopped()) return 0;
            first = 2 * hi + lo;
        }
        // The coefficients it found still insignificant learn their plane in settle_known().
        if (!any) return kRun;
        run_known_ = first;
        const int32_t id = layout_.order[k + first];
        if (!become_significant(m, state, k + first, id, p, value[id])) return 0;
        known[id] = static_cast<uint8_t>(p);
        return first + 1;
    }

    bool run_pass(int pass, int c, int b, int p) {
        const CodingBand& band = layout_.bands[b];
        BandModels& m = models_[model_group(b) * 4 + channel_class(c)];
        uint8_t* state = state_[c].data();
        Value* value = value_[c].data();
        uint8_t* known = known_[c].data();
        const uint8_t* near = near_[c].data();
        c_ = c;
        if (band_ != b) {
            band_ = b;
            if (grid_) set_grid_star();
        }
        if (pass == 0) {
            // Significance where a neighbour or parent is significant: the candidates, which are
            // exactly the coefficients not significant with a significant neighbour or parent.
            return for_each_set(candidates_[c].data(), band.begin, band.end, [&](int32_t k) {
                const int32_t id = layout_.order[k];
                const int nb = significant_neighbours(near, id);
                const int pa = parent_significant(state, id);
                return significance(m, state, k, id, p, nb, pa, value[id], known[id]);
            });
        }
        if (pass == 1) {
            // Refinement of the coefficients significant before this plane.
            return for_each_set(significant_[c].data(), band.begin, band.end, [&](int32_t k) {
                const int32_t id = layout_.order[k];
                if (known[id] == p) return true;
                const int ctx = (state[id] & kRefined)             ? 2
                                : significant_neighbours(near, id) ? 1
                                                                   : 0;
                const int bit = side_.bit(m.refinement[ctx], (std::abs(value[id]) >> p) & 1);
                if (side_.stopped()) return false;
                if constexpr (std::is_same_v<Side, DecodeSide>) {
                    if (bit) value[id] += value[id] < 0 ? -(1 << p) : 1 << p;
                }
                state[id] |= kRefined;
                known[id] = static_cast<uint8_t>(p);
                return true;
            });
        }
        // Significance of the rest, isolated coefficients kRun at a time where they line up, and
        // with `blocks` in a band of kBlockBand or more first kBlock[0], then kBlock[1] at a time
        // (zero blocks). A block found to hold a significant coefficient is coded by its smaller
        // blocks or runs; while none of them has found it, the last one is known to hold it and
        // its decision is not coded. open[i]: where the last block of kBlock[i] that holds one
        // ends (a known last block needs found_ still at opened[i]; inside it, blocks and runs
        // take their own models).
        const bool blocks = options_.blocks && band.end - band.begin >= kBlockBand;
        int32_t open[2] = {-1, -1};
        int64_t opened[2] = {0, 0};
        const auto forced = [&](int level, int32_t end) {
            return open[level] == end && opened[level] == found_;
        };
        for (int32_t k = band.begin; k < band.end; ++k) {
            const int32_t r = k - band.begin;
            if (blocks && r % kBlock[1] == 0) {
                int skip = 0;
                for (int i = 0; i < 2; ++i) {
                    const int n = kBlock[i];
                    if (r % n != 0 || k + n > band.end || !isolated(c, k, n)) continue;
                    int any = 1;
                    if (i == 0 || !forced(0, k + n)) {
                        if constexpr (std::is_same_v<Side, EncodeSide>)
                            any = block_any(value, k, n, p);
                        any = side_.bit(blocks_[channel_class(c)].block[i][i > 0 && k < open[0]],
                                        any);
                        if (side_.stopped()) return stopped_at(c, b, p, k);
                    }
                    if (!any) {
                        skip = n;
                        break;
                    }
                    open[i] = k + n;
                    opened[i] = found_;
                }
                if (skip) {
                    k += skip - 1;
                    continue;
                }
            }
            if (r % kRun == 0 && k + kRun <= band.end && isolated_run(c, k)) {
                const int settled =
                    run(m, state, value, known, k, p, blocks && forced(1, k + kRun), k < open[1]);
                if (settled == 0) return stopped_at(c, b, p, k + run_known_);
                k += settled - 1;
                continue;
            }
            const int32_t id = layout_.order[k];
            if ((state[id] & kSignificant) || known[id] == p) continue;
            const int nb = significant_neighbours(near, id), pa = parent_significant(state, id);
            if (!significance(m, state, k, id, p, nb, pa, value[id], known[id])) {
                return stopped_at(c, b, p, k);
            }
        }
        swept_[c][b] = static_cast<uint8_t>(p);
        return true;
    }

    // Pass 2 of plane p of band b (channel c) stopped at position k: the coefficients before it
    // were visited. Returns false.
    bool stopped_at(int c, int b, int p, int32_t k) {
        stop_ = {c, b, p, k};
        return false;
    }

    // The decoder's `known` of the coefficients still insignificant: run mode visits them without
    // writing it (a store through `order` a coefficient and plane, a tenth of a decode), so each
    // takes here the lowest plane its band's pass 2 completed (every plane visits every
    // insignificant coefficient once, in pass 0 or pass 2), or the plane of a pass 2 that stopped
    // past it. The same values as writing them on the way.
    void settle_known() {
        if constexpr (std::is_same_v<Side, DecodeSide>) {
            for (size_t c = 0; c < value_.size(); ++c) {
                const uint8_t* state = state_[c].data();
                uint8_t* known = known_[c].data();
                for (size_t b = 0; b < layout_.bands.size(); ++b) {
                    const uint8_t lowest = swept_[c][b];
                    if (stop_.c == static_cast<int>(c) && stop_.b == static_cast<int>(b)) {
                        const CodingBand& band = layout_.bands[b];
                        for (int32_t k = band.begin; k < band.end; ++k) {
                            const int32_t id = layout_.order[k];
                            const int plane = k < stop_.k ? std::min<int>(lowest, stop_.p) : lowest;
                            if (!(state[id] & kSignificant))
                                known[id] = static_cast<uint8_t>(std::min<int>(known[id], plane));
                        }
                        continue;
                    }
                    // Branch-free, so that a grid's rows vectorize.
                    const auto settle = [&](size_t id) {
                        const uint8_t lower = std::min(known[id], lowest);
                        known[id] = (state[id] & kSignificant) ? known[id] : lower;
                    };
                    for_band(
                        layout_, b,
                        [&](size_t first, int width) {
                            for (int i = 0; i < width; ++i) settle(first + static_cast<size_t>(i));
                        },
                        [&](int32_t id) { settle(static_cast<size_t>(id)); });
                }
            }
        }
    }

    const CodingLayout& layout_;
    const PlaneCounts& planes_;
    const BitplaneOptions& options_;
    std::vector<std::span<Value>> value_;
    std::vector<std::vector<uint8_t>>& known_;
    Side& side_;
    std::vector<std::vector<uint8_t>> state_;
    std::vector<std::vector<uint8_t>> near_;  // significant neighbour counts per coefficient
    // Per channel, bits by position: pass 0's candidates (not significant, a significant
    // neighbour or parent) and the significant coefficients, so that passes 0 and 1 skip the rest.
    std::vector<std::vector<uint64_t>> candidates_, significant_;
    std::vector<int32_t> position_;  // of each coefficient id in `order` (empty: the identity)
    // Per channel and band, the lowest plane whose pass 2 completed (kNone: none), and where a
    // pass 2 stopped (the stream ran out), for settle_known().
    std::vector<std::vector<uint8_t>> swept_;
    struct Stop {
        int c = -1, b = -1, p = 0;
        int32_t k = 0;
    };
    Stop stop_;
    int run_known_ = 0;  // see run()
    int64_t found_ = 0;  // coefficients found significant so far (pass 2's zero blocks)
    int c_ = 0;          // the channel being coded
    int band_ = -1;      // and the band
    // Grid layouts, the band being coded: its 8 neighbour offsets as ids and as positions, their
    // steps, and what each adds to a neighbour's counts (1 primary, 16 other).
    struct GridStar {
        int32_t id[8], position[8];
        int8_t dx[8], dy[8];
        uint8_t add[8];
    };
    GridStar star_{};
    std::vector<BandModels> models_;
    std::array<BlockModels, 3> blocks_{};  // per channel class
    bool grid_;  // the relations are computed from the layout's grid bands
};

void check_planes(const CodingLayout& layout, const PlaneCounts& planes,
                  const BitplaneOptions& options) {
    for (const auto& channel : planes) {
        if (channel.size() != layout.bands.size()) {
            throw Error(str("bit-plane coder: ", channel.size(), " plane counts for ",
                            layout.bands.size(), " bands"));
        }
        for (uint8_t n : channel) {
            if (n > 31) throw Error(str("bit-plane coder: ", int{n}, " planes (at most 31)"));
        }
    }
    if (!options.shifts.empty() && options.shifts.size() != layout.bands.size()) {
        throw Error("bit-plane coder: one shift per band expected");
    }
    for (int s : options.shifts) {
        if (s < 0 || s > 32) throw Error(str("bit-plane coder: band shift ", s, " out of range"));
    }
}

}  // namespace

PlaneCounts count_planes(const CodingLayout& layout, std::span<const std::span<const int32_t>> q) {
    PlaneCounts planes(q.size(), std::vector<uint8_t>(layout.bands.size(), 0));
    for (size_t c = 0; c < q.size(); ++c) {
        for (size_t b = 0; b < layout.bands.size(); ++b) {
            uint32_t largest = 0;
            if (!layout.grid_bands.empty()) {  // rectangles of the Mallat plane, row by row
                const GridBand& r = layout.grid_bands[b];
                const int width = r.width;
                for (int y = r.y0; y < r.y0 + r.height; ++y) {
                    const int32_t* row =
                        q[c].data() + static_cast<size_t>(y) * layout.grid_width + r.x0;
                    for (int i = 0; i < width; ++i) {
                        largest = std::max(largest, static_cast<uint32_t>(std::abs(row[i])));
                    }
                }
            } else {
                for (int32_t k = layout.bands[b].begin; k < layout.bands[b].end; ++k) {
                    largest =
                        std::max(largest, static_cast<uint32_t>(std::abs(q[c][layout.order[k]])));
                }
            }
            planes[c][b] = static_cast<uint8_t>(std::bit_width(largest));
        }
    }
    return planes;
}

std::vector<uint8_t> encode_bitplanes(const CodingLayout& layout,
                                      std::span<const std::span<const int32_t>> q,
                                      const PlaneCounts& planes, const BitplaneOptions& options) {
    check_planes(layout, planes, options);
    if (planes.size() != q.size()) throw Error("bit-plane coder: one plane count per channel");
    for (auto plane : q) {
        if (static_cast<int32_t>(plane.size()) != layout.size) {
            throw Error("bit-plane coder: plane size does not match the layout");
        }
    }
    std::vector<std::vector<uint8_t>> known = filled<uint8_t>(q.size(), layout.size, kNone);
    EncodeSide side(options.max_bytes);
    Traversal<EncodeSide>(layout, planes, options, {q.begin(), q.end()}, known, side).run();
    return side.finish();
}

DecodedPlanes decode_bitplanes(const CodingLayout& layout, const PlaneCounts& planes,
                               std::span<const uint8_t> stream, const BitplaneOptions& options) {
    check_planes(layout, planes, options);
    DecodedPlanes out;
    out.value = filled<int32_t>(planes.size(), layout.size, 0);
    out.known = filled<uint8_t>(planes.size(), layout.size, kNone);
    DecodeSide side(stream);
    out.complete = Traversal<DecodeSide>(layout, planes, options,
                                         {out.value.begin(), out.value.end()}, out.known, side)
                       .run();
    return out;
}

}  // namespace tesswave
