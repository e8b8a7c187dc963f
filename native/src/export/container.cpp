// What the container encoders share: the chain check and the dispatch table.
#include "iblbake/export/container.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace iblbake {

void check_chain(const CubeChain& chain) {
    if (chain.levels.empty()) throw std::invalid_argument("a cube chain needs at least one level");
    const int n0 = chain.levels[0]->size;
    if (n0 < 1) throw std::invalid_argument("a cube chain's base level is empty");
    for (size_t m = 0; m < chain.levels.size(); ++m) {
        const int want = std::max(1, n0 >> m);
        if (chain.levels[m]->size != want)
            throw std::invalid_argument("level " + std::to_string(m) + " of a cube chain has face " +
                                        std::to_string(chain.levels[m]->size) + ", expected " + std::to_string(want));
        if (m > 0 && chain.levels[m - 1]->size == 1)
            throw std::invalid_argument("a cube chain goes on past its 1 x 1 level");
    }
}

void pack_face(const Cubemap& cube, Mirror m, int face, PixelFormat f, uint8_t* out, PackStats& stats) {
    const size_t row_bytes = size_t(cube.size) * texel_bytes(f);
    for (int j = 0; j < cube.size; ++j) {
        const RowSource r = mirrored_row(cube, m, face, j);
        pack_texels(r.first, size_t(cube.size), f, out + j * row_bytes, stats, r.step);
    }
}

Encoder encoder_for(Container c) {
    switch (c) {
        case Container::Ktx2: return &encode_ktx2;
        case Container::Dds: return &encode_dds;
        case Container::Ktx1: return &encode_ktx1;
        case Container::Env: return &encode_env;
        case Container::Source: break;
    }
    throw std::invalid_argument(std::string("no cube encoder for container ") + container_name(c));
}

}  // namespace iblbake
