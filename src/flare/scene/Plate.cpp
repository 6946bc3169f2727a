#include "flare/scene/Plate.h"

#include <cmath>
#include <cstdio>

#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfMultiPartInputFile.h>
#include <OpenEXR/ImfStandardAttributes.h>

#include "flare/core/Error.h"
#include "flare/film/ImageIO.h"

namespace flare {

namespace {

// The first part's chromaticities, when the file has them.
std::optional<std::array<double, 8>> fileChromaticities(const std::string& path) {
    try {
        Imf::MultiPartInputFile file(path.c_str());
        const Imf::Header& header = file.header(0);
        if (!Imf::hasChromaticities(header)) return std::nullopt;
        const Imf::Chromaticities& c = Imf::chromaticities(header);
        return std::array<double, 8>{c.red.x, c.red.y, c.green.x, c.green.y, c.blue.x, c.blue.y, c.white.x, c.white.y};
    } catch (const std::exception& e) {
        throw InputError(path, 0, std::string("cannot read the EXR header: ") + e.what());
    }
}

}  // namespace

Plate readPlate(const std::string& path, const std::string& colourSpace) {
    // The main RGB layer over the display window (readExrLayer names the layers there are when it
    // has none, and says when the file is not an EXR).
    ImageLayer main = readExrLayer(path, "");
    Plate plate;
    plate.path = path;
    plate.width = main.width;
    plate.height = main.height;
    plate.rgb = std::move(main.rgb);
    static const char* kChannel = "RGB";
    for (size_t i = 0; i < plate.rgb.size(); ++i) {
        if (std::isfinite(plate.rgb[i])) continue;
        const size_t pixel = i / 3;
        char where[160];
        std::snprintf(where, sizeof where, "pixel (%zu, %zu) (column, row from the top left) has %s in %c: a plate must be finite",
                      pixel % plate.width, pixel / plate.width, std::isnan(plate.rgb[i]) ? "NaN" : "an infinity",
                      kChannel[i % 3]);
        throw InputError(path, 0, where);
    }
    if (!colourSpace.empty()) {
        plate.space = resolveColourSpace(colourSpace);
    } else if (const std::optional<std::array<double, 8>> xy = fileChromaticities(path)) {
        const std::string known = knownColourSpaceName(*xy);
        plate.space = colourSpaceFromChromaticities(*xy, known.empty() ? "the file's primaries" : known,
                                                    "the file's chromaticities");
    } else {
        plate.space = resolveColourSpace("linear Rec.709");
        plate.space.source = "no chromaticities in the file: OpenEXR's default";
    }
    return plate;
}

}  // namespace flare
