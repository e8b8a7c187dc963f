// A pyramid of exact lat-long bins (ibl/source.h: integrals of SPEC's
// bilinear L) for hierarchical kernel sums: level 0 is the finest grid
// (w x w/2, w a power of two), each coarser level sums 2 x 2 bins exactly.
// Each bin keeps the zeroth, first and second moments of its radiance, as
// floats, structure-of-arrays; a bin whose colour varies keeps its channels'
// means too (ChromaBin).
#pragma once
#include <cstdint>
#include <functional>
#include <utility>
#include <vector>

#include "iblbake/image/image.h"
#include "iblbake/ibl/source.h"

namespace iblbake {

// One bin as the hierarchical sum reads it, in one cache line.
struct alignas(64) BinNode {
    // Where the bin's radiance sits: m = integral of L w dOmega / integral of
    // L dOmega (channel sums), kept as its unit direction p and g = 1 - |m|
    // (the kernel takes n.m as n.((1 - g) p): specular_kernel_impl.h, with
    // what its rounding costs at the narrowest lobe).
    float px, py, pz, g;
    // Power per channel: integral of L_c dOmega.
    float power[3];
    // Covariance of w under the bin's radiance (channel sums), engine space:
    // xx, yy, zz, xy, xz, yz. n^T C n is the variance of n.w over the bin.
    float cov[6];
    // Angular radius about p: the largest angle from p to the bin's corners
    // and edge midpoints (radians); negative for a bin with no radiance.
    float radius;
    // 0, or where this bin's ChromaBin is (BinTree::chroma_of), and then
    // its scores min(1, s_c) (below), 10 bits each from bit 10 c, rounded
    // up: chroma_score(c).
    uint32_t chroma;
    uint32_t chroma_scores;
    float chroma_score(int c) const { return float(chroma_scores >> (10 * c) & 1023u) * (1.0f / 1023.0f); }
};
static_assert(sizeof(BinNode) == 64, "a bin is one cache line");

// Issue 25: the second-order rule (specular.h) takes a bin's radiance in
// every channel at the channel sum's mean m and covariance C. Channel c's own
// mean m_c = V_c / P_c is exact (the bins keep the first moments per
// channel), and so is its spread, tr C_c = 1 - |m_c|^2 (w is a unit
// vector). Where they differ from the sum's, channel c's term
// E_c[k(n.w)] is off by about (Taylor expansion about n.m, as for the rule)
//   k'(n.m) n.d + k''(n.m)/2 n^T (C_c - C + d d^T) n,   d = m_c - m,
// that is, relative to the bin's share in channel c, with the kernel's
// derivatives in units of its length scale l at the bin (a bin of radius
// beta is taken whole where beta <= eps l), of order s_c beta / l with
//   s_c = |d| / beta + (|tr C_c - tr C| + |d|^2) / (2 beta^2)
// (the trace standing for the covariance, which the bins keep for the sum
// alone). A bin with max_c a_c s_c above the build's tolerance, a_c =
// min(1, 20 P_c / (Omega mean_c)) its mean radiance in c against the
// metric's floor 0.05 x mean_c (darker bins can only move darker texels),
// keeps each channel as a bin of that channel's power, its exact mean, and
// the sum's covariance scaled to the channel's trace,
// C_c = C (1 - |m_c|^2) / (1 - |m|^2). specular.cpp takes a bin as its
// channels where its error in some channel matters to the texels at hand.
// (Keeping two channels together where they were alike saved under 1 % of
// the bins and left studio.exr 1.3 % off in green: measured, issue 25.)
struct ChromaChannel {
    float px, py, pz, g;  // unit centroid and 1 - |m_c|, as BinNode's
    float cov_scale;      // C_c = cov_scale x BinNode::cov
};
struct ChromaBin {
    ChromaChannel channel[3];
};

struct BinLevel {
    int w = 0, h = 0;
    BigVector<BinNode> nodes;  // every node written by the builder
    size_t index(int x, int y) const { return size_t(y) * w + x; }
};

struct BinTree {
    std::vector<BinLevel> levels;  // [0] finest
    // The bins of varying colour, by row (every level's rows in turn), in
    // order: a node's chroma is (1 + its row's index) << 12 | its index in
    // the row (rows hold at most 4096 bins).
    std::vector<std::vector<ChromaBin>> chroma;
    double channel_mean[3] = {0, 0, 0};
    const ChromaBin& chroma_of(const BinNode& nd) const { return chroma[(nd.chroma >> 12) - 1][nd.chroma & 4095u]; }
    size_t chroma_count() const {
        size_t n = 0;
        for (const auto& r : chroma) n += r.size();
        return n;
    }
};

struct BinTreeOptions {
    // Bins with max_c a_c s_c above this keep their channels' moments
    // (measured with HierarchicalQuality::chroma 0.01, issue 25: 0.04 left
    // sunset.exr 1.2 % off in blue; 0.01 kept 2.5x the bins of varying
    // colour for 0.41 % instead of 0.67 % there).
    double chroma_tolerance = 0.02;
    // The image's mean radiance per channel (a_c's mean_c); null: computed.
    const double* channel_mean = nullptr;
    // build_bin_tree: when set, the finest rows are reduced in order and
    // source_done(y) is called (y never decreasing, the last call with the image's
    // height) as soon as the build will read no source row above y again,
    // so that a caller that owns the source can let those rows go
    // (RowRelease). The tree is the same either way.
    std::function<void(int)> source_done;
    // build_bin_tree: when set, receives project_sh9_bilinear(latlong,
    // finest_w) to the bit, from the reduction the tree is built from.
    std::array<Sh9, 3>* sh9 = nullptr;
};

// The colour test of one exact bin (above) and, for a bin that passes, its
// scores (BinNode::chroma_scores) and per-channel moments. The tree builds
// its rows eight bins at a time with vector copies of these that give the
// same bits (BinTree.ColourTestAndChannelMomentsAreTheirDefinitions).
// a_scale[c] = 20 / mean_c (0 for a mean of 0), so that a bin of power P_c
// and solid angle 1 / inv_omega has a_c = min(1, a_scale[c] P_c inv_omega);
// beta: the bin's radius; tol: BinTreeOptions::chroma_tolerance.
void colour_weight_scales(const double* channel_mean, double* a_scale);
bool bin_colour_varies(const Bin& b, double beta, double inv_omega, const double* a_scale, double tol);
uint32_t bin_channel_moments(const Bin& b, double beta, ChromaBin& out);

// finest_w: bins across at level 0 (a power of two >= 2). With `keep`, the
// exact bins (ibl/source.h) at keep_w across (a power of two in 2..finest_w/4)
// are copied there on the way: another reduction of the same image for free.
BinTree build_bin_tree(ImageView latlong, int finest_w, std::vector<Bin>* keep = nullptr, int keep_w = 0,
                       const BinTreeOptions& options = {});

// build_bin_tree as a source is decoded in bands (issue 28,
// docs/design-streaming.md): add_rows() reduces every bin row of level 0
// whose source rows (source_rows(br), the hats' reach) all lie in y0..y1 of
// `img` (a view whose rows y0..y1 are readable, e.g. a row table into a
// band) and keeps level 0's exact bins (w x w/2 x 144 bytes: 19 MB at 512
// across) until finish() builds the tree from them, once the channel means
// (the chroma test's) are known. The tree, `keep` included, equals
// build_bin_tree(whole image, finest_w, keep, keep_w, options with those
// means) to the bit. Bands must overlap by the rows a bin row needs beyond
// its own (one row of hat on each side).
class BinRowStream {
public:
    // sh9 false: no SH9 per bin row (sh9() throws std::logic_error).
    BinRowStream(int img_w, int img_h, int finest_w, bool sh9 = true);
    void add_rows(ImageView img, int y0, int y1);
    std::pair<int, int> source_rows(int br) const;  // first and last source row bin row br reads
    // The most rows one bin row reads: bands of B rows overlapping by
    // max_reach() - 1 rows (start k at k (B - max_reach() + 1)) serve every bin row.
    int max_reach() const;
    // max_reach() of a BinRowStream(any width, img_h, finest_w), from the
    // latitude pieces alone (before the stream is made; max_reach() is this).
    static int reach(int img_h, int finest_w);
    int pending() const;                            // bin rows not yet reduced
    BinTree finish(const double* channel_means, std::vector<Bin>* keep = nullptr, int keep_w = 0,
                   const BinTreeOptions& options = {});
    // Level 0's exact bins alone, row-major (no tree): what
    // reduce_to_bins(whole image, finest_w, finest_w / 2) gives, to the bit.
    std::vector<Bin> take_bins();
    // project_sh9_bilinear(whole image, finest_w) to the bit (every bin row reduced).
    std::array<Sh9, 3> sh9() const;

private:
    int w_, img_h_;
    BinReduction red_;
    std::vector<Bin> bins_;
    std::vector<std::array<Sh9, 3>> sh9_rows_;
    std::vector<char> done_;
};

}  // namespace iblbake
