// bake: composes the integrators of ibl/ into SPEC.md's outputs (this
// header) and keeps the LUT cache (lut_cache.h), its only files. It knows no
// preset, container or output folder: compute_bake() does no I/O, and
// pipeline/ plans a bake, runs it and writes its files (pipeline/write.h).
#pragma once
#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "iblbake/ibl/brdf_lut.h"
#include "iblbake/ibl/source.h"
#include "iblbake/ibl/specular.h"
#include "iblbake/ibl/sun.h"
#include "iblbake/image/image.h"

namespace iblbake {

struct Skip {
    std::string what, why;
};

enum class SpecularMethod {
    Hierarchical,  // deterministic Barnes-Hut kernel sum over exact bins (default)
    Fis,           // filtered importance sampling of a cube pyramid + exact hot texels
};

const char* specular_method_name(SpecularMethod m);
SpecularMethod specular_method_from_name(const std::string& name);  // throws std::invalid_argument

// The sun as a light (issue 27, ibl/sun.h): off, or found, taken out of the
// environment before anything is integrated, and handed back as a light.
enum class SunMode { Off, Split };
const char* sun_mode_name(SunMode m);
SunMode sun_mode_from_name(const std::string& name);  // throws std::invalid_argument

// Outputs beyond SPEC's, for engine exports (pipeline/plan.h fills this from
// the presets asked for): more specular levels, each integrated at its own
// roughness, and what else a preset writes.
struct SpecularLevelRequest {
    int face_size = 0;
    double roughness = 0.0;
};
struct ExtraOutputs {
    std::vector<SpecularLevelRequest> specular;  // not already among SPEC's levels
    bool irradiance = false;                     // the irradiance cube even when `irradiance` is off
    std::vector<LutModel> luts;                  // LUTs of more models, at lut_size
    bool keep_source = false;                    // the cleaned source image in the result
    bool any() const { return !specular.empty() || irradiance || !luts.empty() || keep_source; }
};

struct BakeOptions {
    int face_size = 256;        // specular mip 0
    int irradiance_size = 32;
    int mip_count = 0;          // 0: floor(log2(face_size)) + 1
    int lut_size = 512;
    // Only specular levels first_level .. last_level (-1: the last) are baked;
    // the others are listed in `skipped` (roughness r_m still counts all M levels).
    int first_level = 0, last_level = -1;
    LutModel lut_model = LutModel::Karis;
    bool irradiance = true, specular = true, lut = true;
    std::vector<Skip> skip_reasons;  // why an output is off (else "disabled by option")

    SpecularMethod specular_method = SpecularMethod::Hierarchical;
    HierarchicalQuality hierarchical;
    SpecularQuality specular_quality;  // for SpecularMethod::Fis
    LutQuality lut_quality;
    int specular_base_face = 0;       // FIS: rest cube face; 0: automatic
    int irradiance_bins = 128;        // lat-long bins across (half as many down), a power of two
    int irradiance_exact_face = 128;  // larger irradiance faces are resampled from this
    double hot_threshold = 16.0;      // hot texels: above this times the mean ...
    int max_hot = 1024;               // ... and at most this many
    bool strict = false;              // bad texels are an error instead of 0
    // The world turned about its up axis (Blender's Z), in degrees, as
    // Blender's Mapping node (Point, rotation Z) turns an Environment Texture:
    // direction d shows the source's L(Rz(rotation) d).
    double rotation = 0.0;
    // Split: the dominant compact light source (the sun) is found in the
    // cleaned, turned source and replaced by the sky behind it; every output
    // is baked from that sun-free source and the result holds the light.
    SunMode sun = SunMode::Off;
    int threads = 0;                  // 0: all cores
    ExtraOutputs extra;               // for engine presets
    // The caller's warnings (an odd file, an ignored option, ...): the
    // result's `warnings` start with them.
    std::vector<std::string> warnings;

    // Throws std::invalid_argument naming the option at fault.
    void validate() const;
    int resolved_mip_count() const;
    int resolved_last_level() const;
    double mip_roughness(int level) const;  // SPEC: r_m = m / (M - 1)
};

struct ExtraSpecularLevel {
    int face_size = 0;
    double roughness = 0.0;
    Cubemap cube;
    size_t samples_per_texel = 0;
    std::string method;
};

struct BakeResult {
    std::optional<Cubemap> irradiance;
    std::vector<Cubemap> specular;
    std::vector<int> specular_levels;  // mip level of each entry of `specular`
    std::vector<double> roughness;
    std::optional<Image> lut;
    // The sha256 of lut's pixels when the LUT cache gave it (the entry's own
    // checksum took it, or store() did), else empty: the key of the LUT's
    // encoded files (encoded_lut_key) without hashing the table again.
    std::string lut_sha256;
    std::array<Sh9, 3> sh9{};
    BadInputCounts bad_input;
    std::vector<Skip> skipped;
    std::vector<std::pair<std::string, double>> timings;  // seconds per stage
    // Diagnostics, recorded in the manifest.
    std::array<double, 3> mean_radiance{};
    size_t hot_texels = 0;
    double hot_threshold = 0.0, hot_power_fraction = 0.0;
    int specular_base_face = 0;  // FIS: rest cube face; hierarchical: finest bins across
    std::vector<size_t> samples_per_texel;  // per specular level (bins per texel, hierarchical)
    std::vector<std::string> specular_methods;
    bool lut_from_cache = false;
    // The instruction set the hierarchical specular sum ran on (ibl/specular.h's
    // specular_kernel_isa()); empty when no level used it.
    std::string specular_kernel;
    int integration_width = 0, integration_height = 0;  // the grid the integrals ran on
    // What options.extra asked for (engine presets).
    std::vector<ExtraSpecularLevel> extra_specular;
    std::optional<Cubemap> extra_irradiance;  // when `irradiance` is off
    std::vector<std::pair<LutModel, Image>> extra_luts;
    std::optional<Image> source;              // the cleaned source (keep_source); sun-free with `sun`
    // With SunMode::Split: the light (found or not, and why); the outputs
    // above are the sun-free environment's.
    std::optional<SunLight> sun;
    // Questionable input that was baked anyway (the manifest's `warnings`).
    std::vector<std::string> warnings;
};

struct Cancelled : std::runtime_error {
    Cancelled() : std::runtime_error("bake cancelled") {}
};
struct BadInputError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

// Called between stages with a fraction in [0, 1]; return false to cancel
// (the bake then throws Cancelled and nothing is written).
using ProgressFn = std::function<bool(const std::string& stage, double fraction)>;

class LutCache;

// Receives each output as soon as the bake has made it ("irradiance",
// "specular_<m>", the LUT), final (scaled back, never changed again), so
// that writing it (pipeline/write.h's BakeWriter) overlaps the rest of the bake.
// The references stay valid until wait() returns; the bake calls wait()
// before it returns or throws.
class OutputSink {
public:
    virtual ~OutputSink() = default;
    virtual void cube(const std::string& stem, const Cubemap& cube) = 0;
    // A sink whose caller needs the files alone (no preview or export reads
    // the result's pixels afterwards) takes the cubes instead: the bake
    // checks a cube's values, then hands its pixels over with take_cube()
    // and keeps only its size in the result; the sink frees them once
    // written (issue 25: mip 0 was held to the end of the bake, through its
    // peak, long after its file was done).
    virtual bool takes_cubes() const { return false; }
    virtual void take_cube(const std::string& stem, Cubemap&& cube);  // (the default throws std::logic_error)
    // pixels_sha256: BakeResult::lut_sha256 (may be empty).
    virtual void lut(const Image& lut, const std::string& pixels_sha256) = 0;
    virtual void wait() = 0;  // everything handed over is done with; rethrows its first failure
};

// The whole bake in memory. `source` is a Blender lat-long image; it is
// cleaned in place (SPEC.md section 1). Every output is checked to be
// finite before the bake returns: a non-finite value (a source changed
// while it was read, a damaged table) makes it throw std::runtime_error
// instead of reporting success. With a `lut_cache`, the LUT is read
// from it when present and stored into it when made. With a `sink`, every
// SPEC output is handed to it as soon as it is made (the extra outputs
// stay in the result, for the exports).
BakeResult compute_bake(Image source, const BakeOptions& options, const ProgressFn& progress = {},
                        LutCache* lut_cache = nullptr, OutputSink* sink = nullptr);
// The same bake of pixels owned elsewhere (a numpy array): a clean source is
// read where it lies, one with bad or overflowing values is copied first.
BakeResult compute_bake_view(ImageView source, const BakeOptions& options, const ProgressFn& progress = {},
                             LutCache* lut_cache = nullptr, OutputSink* sink = nullptr);

// A source handed over a band of rows at a time (a file decoded as the bake
// goes; issue 28, docs/design-streaming.md): read(y0, rows, out) writes rows
// y0 .. y0 + rows - 1 as rows x width x 3 linear RGB floats. Rows are asked
// for once each, in order; preferred_band() is the band a read decodes best.
// A source whose rows are IEEE halves (has_halves()) is read by
// read_halves() instead, rows x width x 3 of them, and each row made floats
// by the pass that reduces it, while the row is in that core's cache (a
// 16K band of floats is 25 MB: converted by the reader, it had left the
// cache before it was read).
class BandSource {
public:
    virtual ~BandSource() = default;
    virtual int width() const = 0;
    virtual int height() const = 0;
    virtual int preferred_band() const = 0;
    virtual void read(int y0, int rows, float* out) = 0;
    virtual bool has_halves() const { return false; }
    virtual void read_halves(int /*y0*/, int /*rows*/, uint16_t* /*out*/) {
        throw std::logic_error("BandSource::read_halves: the rows are not halves");
    }
};

// Why a bake with these options needs the whole source in memory (a turn,
// the sun split, FIS, the source preset), or "" when compute_bake_stream()
// can bake it from bands.
std::string whole_source_reason(const BakeOptions& options);
// The memory a streamed bake holds beyond the bands and the outputs, in
// bytes: level 0 of the bin tree (144 bytes a bin: 19 MB at 512 across, 75 MB
// at 1024), the irradiance's own bins when the tree's are too coarse, mip
// 0's lookups. Streaming pays when this is less than the float source (12
// bytes a texel).
double stream_state_bytes(const BakeOptions& options);

// The bake of a source read in bands, never held whole: the same outputs as
// compute_bake() of the image the rows make, to the bit (each stage's
// per-row arithmetic is today's, on views of the band). Its memory is the
// bands' and the outputs', whatever the source's size. Requires
// whole_source_reason(options) to be "". Returns nothing (having handed the
// sink nothing) when the source holds values of 2^64 or more, or none of
// 2^-64 or more but some above 0, which the overflow guard must scale
// first: bake the whole image then.
std::optional<BakeResult> compute_bake_stream(BandSource& source, const BakeOptions& options,
                                              const ProgressFn& progress = {}, LutCache* lut_cache = nullptr,
                                              OutputSink* sink = nullptr);

// The bake of a constant world of radiance `rgb` (a plain-colour world), in
// closed form: Irr = Pre = rgb everywhere, SH9 = rgb * 2 sqrt(pi) in L_00
// alone. The LUT is made (or read from the cache) as in compute_bake.
BakeResult compute_constant_bake(const std::array<float, 3>& rgb, const BakeOptions& options,
                                 const ProgressFn& progress = {}, LutCache* lut_cache = nullptr,
                                 OutputSink* sink = nullptr);

// Just the LUT (it depends on nothing but its own settings).
Image compute_lut(int size, LutModel model, const LutQuality& q = {}, int threads = 0);

}  // namespace iblbake
