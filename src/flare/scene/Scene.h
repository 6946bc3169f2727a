// The scene file (JSON, docs/scene-format.md): which lens at which zoom/focus/f-stop, the lights,
// the sensor and the render settings. Plain data: the lens is named here, not loaded, so that
// the scene can be read, checked and reported on without touching the optics. Every problem in a
// scene file raises InputError naming the file, the line of the offending value and its key path
// (e.g. "lights[1].angular_diameter_deg").
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "flare/core/Spectrum.h"
#include "flare/optics/LensPrescription.h"
#include "flare/optics/LensSystem.h"
#include "flare/photons/Light.h"

namespace flare {

struct SensorSettings {
    // Physical size. Both empty: the lens's sensor. One given: the other follows from the
    // resolution (square pixels); the parser fills it in.
    std::optional<double> widthMm, heightMm;
    int widthPx = 1536, heightPx = 1024;
};

struct RenderSettings {
    int previewWavelengths = 5;           // wavelengths per preview pass
    int ghostOrder = 2;                   // reflections per enumerated ghost path: 2 or 4
    double pruneKeepShare = 0.999;        // keep the strongest ghosts holding this share of power
    double pruneRelativeThreshold = 1e-5; // ...and drop any ghost below this share of the total
    std::int64_t photons = 10'000'000;    // photon budget of the photon tracer
    std::uint64_t seed = 1;
    int maxBounces = -1;                  // reflections per photon path; −1: unbounded (roulette)
    bool includeSensorGhosts = true;      // paths that reflect off the sensor
    bool diffraction = true;              // the starburst: the direct image convolved with the PSF
    int diffractionWavelengths = 32;      // spectral quadrature of the diffraction PSF
    int beamsPerPass = 1024;              // per directional light (RenderOptions::beamsPerPass)
    bool beamsByPower = false;            // the pass's beams shared by the lights' power (SceneBeamShare.h)
    bool ghostRinging = true;             // Fresnel ripples on the ghosts' rims (RenderOptions::ghostRinging)
};

// Scattering (docs/scene-format.md, "scattering"). Surfaces are numbered from 1 in file order,
// counting the stop, as everywhere; an element is named by the number of its first surface.
// A coverage mask on a dust or grease entry (CoverageMask): the image file and where it lies on
// the surface. Loaded with the lens (applySceneScattering), whose clear diameter is the default width.
struct MaskSpec {
    std::string file;                  // resolved path; "" = no mask
    std::optional<double> widthMm;     // default: the surface's clear diameter
    std::optional<double> heightMm;    // default: from the width and the image's aspect ratio
    glm::dvec2 centreMm{0.0};
    std::string keyPath;               // e.g. "scattering.dust[0].mask", for errors
    int line = 0;                      // of the "mask" value
};
struct DustSpec {
    int surface = 0;
    double coverage = 0.0, albedo = 0.5, diameterUm = 20.0, diameterSigma = 0.5;
    MaskSpec mask;
    int line = 0;
};
struct GreaseSpec {
    int surface = 0;
    double coverage = 0.0, roughness = 0.1;
    MaskSpec mask;
    int line = 0;
};
struct BulkSpec {
    int element = 0;
    double scatteringPerMm = 0.0, absorptionPerMm = 0.0, g = 0.0;
    bool rayleigh = false;
    std::string grid;      // resolved path of a .vdb ("" = homogeneous)
    std::string gridName;  // "" = the file's first float grid
    int line = 0;
};
// Unset finishes and gloss exponent fall back to the lens file's, then to FinishSpec{} and 30.
// Dust and grease entries replace the lens file's for their surface (FinishSpec, RowDust and
// RowGrease: LensPrescription.h).
struct ScatteringSettings {
    std::optional<FinishSpec> housing, edges, iris;
    std::optional<double> glossExponent;
    std::vector<DustSpec> dust;
    std::vector<GreaseSpec> grease;
    std::vector<BulkSpec> bulk;
};

// 1-based lines in the scene file of the values that can only be checked once the lens is loaded
// (0 when the key is absent), so that those errors still point into the scene.
struct SceneLines {
    int lens = 0, zoom = 0, focus = 0, fNumber = 0, sensor = 0, resolution = 0, coating = 0, glassCatalog = 0;
    std::vector<int> lights;  // the line of each light's opening brace
};

// The scene's `coating`: replaces the lens's coating on every air–glass surface. Either a coating
// name the lens knows (its own, or `none`, `mgf2`) or an ideal reflectance.
struct SceneCoating {
    std::string name;                       // empty when `ideal` is set
    std::optional<IdealReflectance> ideal;
};

struct Scene {
    std::string sourceFile;   // as given to loadScene (or the fileName of parseSceneText)
    std::string description;  // free text, optional
    // Resolved: a path (relative to the scene file's folder, joined with it) of an existing
    // file, or the name of a shipped lens; either can be given to loadLens().
    std::string lens;
    // Private glass catalogues (.agf) the lens's glasses may come from (`glass_catalog`), resolved
    // like `lens`; read with the lens (useGlassCatalog, AgfCatalog.h).
    std::vector<std::string> glassCatalogs;
    LensState lensState;
    std::vector<LightSpec> lights;
    SensorSettings sensor;
    RenderSettings render;
    ScatteringSettings scattering;
    std::optional<SceneCoating> coating;
    SceneLines lines;
};

// Reads and checks a scene file. A missing or unreadable file raises InputError with line 0.
Scene loadScene(const std::string& path);
// Parses scene text already in memory. `fileName` is used in error messages; relative lens paths
// are resolved against `baseDir` ("" = the current directory).
Scene parseSceneText(std::string_view text, const std::string& fileName, const std::string& baseDir);

// The scene used when none is given: the 50 mm double Gauss at f/4 with a sun 13.5° off axis
// (docs/examples/default.json holds the same text).
std::string_view defaultSceneText();
Scene defaultScene();

// Loads the scene's lens and builds it at the scene's zoom/focus/f-stop, with the scene's sensor
// size when it gives one (see sensorSizeMm). Problems with the lens
// file itself name the lens file; a zoom, focus or f-number the lens cannot take names the scene
// file and the line of that key.
LensSystem buildSceneLens(const Scene& scene);

// The sensor's physical size (width, height) in mm: the scene's, or the lens's when the scene
// gives none. Raises InputError (scene file, line of the resolution) if the pixels would not be
// square within 0.1 %.
glm::dvec2 sensorSizeMm(const Scene& scene, const SensorSpec& lensSensor);

}  // namespace flare
