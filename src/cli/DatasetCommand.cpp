#include "DatasetCommand.h"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <tbb/global_control.h>

#include "Output.h"
#include "Processes.h"
#include "flare/core/Error.h"
#include "flare/core/OutputFiles.h"
#include "flare/film/ImageIO.h"
#include "flare/render/Render.h"
#include "flare/scene/DatasetSpec.h"
#include "flare/scene/Scene.h"
#include "flare/scene/SceneRender.h"
#include "flare/scene/SceneStarburst.h"

namespace flare::cli {

namespace {

struct DatasetCommandOptions {
    std::string spec, dir, shard;
    int threads = 0;
    bool quiet = false;
};

std::string imageName(int k) {
    char name[32];
    std::snprintf(name, sizeof name, "image_%06d", k);
    return name;
}

// "i/n" with 0 ≤ i < n.
std::pair<int, int> parseShard(const std::string& text) {
    int i = -1, n = 0;
    char rest = 0;
    if (std::sscanf(text.c_str(), "%d/%d%c", &i, &n, &rest) != 2 || n < 1 || i < 0 || i >= n)
        throw InputError("--shard", 0, "must be i/n with 0 <= i < n (e.g. 0/4), got '" + text + "'");
    return {i, n};
}

// The report's fields that depend on the machine and its load, not on the image.
nlohmann::json withoutTimes(nlohmann::json report) {
    report.erase("wall_time_s");
    report.erase("photons_per_second");
    return report;
}

// Renders image k and writes its EXR and JSON (all or nothing: the JSON marks it finished).
void renderImage(const DatasetSpec& spec, int k, const std::filesystem::path& dir, bool quiet) {
    const std::string name = imageName(k);
    const DatasetImage image = datasetImage(spec, k);
    const Scene scene = parseSceneText(image.scene.dump(), name + ".json", "");
    const LensSystem lens = buildSceneLens(scene);
    SceneRenderOverrides overrides;
    overrides.perGhostLayers = spec.perGhostLayers;
    const RenderOptions options = sceneRenderOptions(scene, lens, overrides);
    Renderer renderer(lens, scene.lights, options);
    // No time limit: the target error and the photon cap depend on the image alone.
    const RenderStopRule stop = RenderStopRule::make(scene, options, spec.photons, 0.0, spec.targetError);
    while (!stop.reached(renderer, 0.0)) renderer.runPass();
    std::optional<StarburstImage> starburst;
    if (scene.render.diffraction)
        starburst = sceneStarburst(scene, lens, renderer.layerXyz(kLayerDirect), options.film.widthPx,
                                   options.film.heightPx);
    const std::vector<ImageLayer> layers = renderLayers(renderer, starburst ? &*starburst : nullptr);

    const std::string exr = (dir / (name + ".exr")).string(), json = (dir / (name + ".json")).string();
    OutputFiles outputs;
    outputs.add(exr, "image");
    outputs.add(json, "image JSON");
    ExrWriteOptions exrOptions;
    exrOptions.compression = ExrCompression::Piz;
    for (const ImageLayer& layer : layers)
        if (layer.name.starts_with("ghost_")) exrOptions.ownParts.insert(layer.name);
    writeExr(outputs, exr, layers,
             {{"software", "flare dataset"},
              {"colorSpace", "linear Rec.709 (sRGB primaries, D65 white)"},
              {"units", "sensor irradiance, W/m2 per the lights' power units; variance layer in (W/m2)^2"},
              {"image", std::to_string(k)},
              {"lens", lens.name()}},
             exrOptions);
    nlohmann::json j;
    j["image"] = k;
    j["exr"] = name + ".exr";
    j["scene"] = image.scene;
    j["drawn"] = image.drawn;
    j["statistics"] = withoutTimes(sceneRenderReportJson(renderer, scene, lens, spec.targetError,
                                                         starburst ? &*starburst : nullptr));
    outputs.write(json, jsonText(j) + "\n");
    outputs.commit();
    if (!quiet)
        std::fprintf(stderr, "dataset: %s (%s, %d passes, error %.2g%%)\n", name.c_str(), lens.name().c_str(),
                     renderer.statistics().passes, 100.0 * renderer.estimatedRelativeError(kGroupFlare));
}

// The index of a complete set, from its images' JSONs: one row per image.
void writeIndex(const DatasetSpec& spec, const std::filesystem::path& dir) {
    nlohmann::json rows = nlohmann::json::array();
    std::ostringstream csv;
    csv << "image,exr,lens,efl_mm,f_number,lights,lights_in_frame,dust,grease,passes,photons,"
           "estimated_error,direct_w,ghost_w,higher_w,scatter_w\n";
    for (int k = 0; k < spec.images; ++k) {
        std::ifstream in(dir / (imageName(k) + ".json"));
        const nlohmann::json j = nlohmann::json::parse(in);
        const nlohmann::json& s = j["statistics"];
        int inFrame = 0;
        for (const nlohmann::json& l : j["drawn"]["lights"]) inFrame += l["in_frame"].get<bool>() ? 1 : 0;
        nlohmann::json row = {{"image", k},
                              {"exr", j["exr"]},
                              {"lens", j["drawn"]["lens"]},
                              {"efl_mm", j["drawn"]["efl_mm"]},
                              {"f_number", j["scene"]["f_number"]},
                              {"lights", j["drawn"]["lights"].size()},
                              {"lights_in_frame", inFrame},
                              {"dust", j["drawn"]["dust"]},
                              {"grease", j["drawn"]["grease"]},
                              {"passes", s["passes"]},
                              {"photons", s["photons"]},
                              {"estimated_error", s["flare_estimated_relative_error"]}};
        for (const char* layer : {"direct", "ghost", "higher", "scatter"})
            row[std::string(layer) + "_w"] = s["layers"][layer]["power_w"];
        csv << k;
        for (const char* key : {"exr", "lens", "efl_mm", "f_number", "lights", "lights_in_frame", "dust", "grease",
                                "passes", "photons", "estimated_error", "direct_w", "ghost_w", "higher_w", "scatter_w"})
            csv << ',' << (row[key].is_string() ? row[key].get<std::string>() : row[key].dump());
        csv << '\n';
        rows.push_back(row);
    }
    OutputFiles outputs;
    outputs.add((dir / "index.csv").string(), "index");
    outputs.add((dir / "index.json").string(), "index");
    outputs.write((dir / "index.csv").string(), csv.str());
    outputs.write((dir / "index.json").string(),
                  jsonText({{"spec", spec.file}, {"images", spec.images}, {"seed", spec.seed}, {"rows", rows}}) + "\n");
    outputs.commit();
}

int run(const DatasetCommandOptions& o) {
    std::unique_ptr<tbb::global_control> threads;
    if (o.threads > 0)
        threads = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, o.threads);
    Processes& processes = Processes::world();
    // Everything is checked before anything is written.
    const DatasetSpec spec = loadDatasetSpec(o.spec);
    const auto [shard, shards] = o.shard.empty() ? std::pair{0, 1} : parseShard(o.shard);
    const std::filesystem::path dir(o.dir);
    std::error_code ec;
    if (std::filesystem::exists(dir, ec) && !std::filesystem::is_directory(dir, ec))
        throw InputError(o.dir, 0, "the data set's output (-o) must be a folder");
    // Image 0's scene, drawn and checked before the folder is made: a spec whose scenes the
    // scene format refuses fails here, with nothing written.
    parseSceneText(datasetImage(spec, 0).scene.dump(), imageName(0) + ".json", "");
    if (processes.root()) std::filesystem::create_directories(dir);
    processes.barrier();

    // This shard's images (k ≡ shard mod shards), and of those this rank's (every size-th).
    std::vector<int> mine;
    int ofShard = 0;
    for (int k = shard; k < spec.images; k += shards, ++ofShard)
        if (ofShard % processes.size() == processes.rank()) mine.push_back(k);
    int rendered = 0, skipped = 0;
    for (int k : mine) {
        if (std::filesystem::exists(dir / (imageName(k) + ".json"), ec)) {
            ++skipped;  // finished by an earlier run
            continue;
        }
        renderImage(spec, k, dir, o.quiet);
        ++rendered;
    }
    processes.barrier();
    if (!processes.root()) return 0;
    int present = 0;
    for (int k = 0; k < spec.images; ++k) present += std::filesystem::exists(dir / (imageName(k) + ".json"), ec) ? 1 : 0;
    if (present == spec.images) writeIndex(spec, dir);
    if (!o.quiet)
        std::fprintf(stderr, "dataset: %d rendered, %d already there%s; %d of %d images in %s%s\n", rendered, skipped,
                     processes.size() > 1 ? " (rank 0's)" : "", present, spec.images, o.dir.c_str(),
                     present == spec.images ? ": index written" : ": the index waits for the other shards");
    return 0;
}

}  // namespace

void addDatasetCommand(CLI::App& app) {
    auto o = std::make_shared<DatasetCommandOptions>();
    CLI::App* dataset = app.add_subcommand(
        "dataset", "render a physically based flare data set from a spec (EXR + JSON per image, an index)");
    dataset->add_option("SPEC", o->spec, "data set spec (JSON, docs/dataset.md)")->required();
    dataset->add_option("-o,--output", o->dir, "folder of the set (created; a run into it resumes)")->required();
    dataset->add_option("--shard", o->shard, "render only images k with k mod n = i (i/n, for job arrays)");
    dataset->add_option("--threads", o->threads, "worker threads per process (default: all cores)")
        ->check(CLI::PositiveNumber);
    dataset->add_flag("--quiet", o->quiet, "no progress on stderr");
    dataset->callback([o] {
        const int code = runOnEveryRank("dataset", [&] { return run(*o); });
        if (code != 0) throw CLI::RuntimeError(code);
    });
}

}  // namespace flare::cli
