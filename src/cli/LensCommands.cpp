#include "LensCommands.h"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "LensOptions.h"
#include "Output.h"
#include <algorithm>
#include <vector>

#include "flare/core/Error.h"
#include "flare/core/NearestNames.h"
#include "flare/core/OutputFiles.h"
#include "flare/core/TextEncoding.h"
#include "flare/ghosts/GhostRays.h"
#include "flare/ghosts/Ghosts.h"
#include "flare/optics/LensCheck.h"
#include "flare/optics/LensDrawing.h"
#include "flare/optics/LensFile.h"
#include "flare/optics/LensInfo.h"
#include "flare/optics/LensLibrary.h"
#include "flare/optics/LensSystem.h"
#include "flare/optics/Paraxial.h"
#include "flare/optics/ZemaxFile.h"

namespace flare::cli {

namespace {

constexpr const char* kLensHelp =
    "lens prescription (.lens, pbrt .dat or Zemax .zmx), the name of a shipped lens such as double-gauss-50mm, or a library id";

void printLensInfo(const nlohmann::json& j) {
    std::printf("%s\n", j["name"].get<std::string>().c_str());
    std::printf("  source               %s\n", j["source"].get<std::string>().c_str());
    if (j.contains("zoom")) {
        const auto& z = j["zoom"];
        // A named position carries the focal length its source states; a focal length asked for
        // is the paraxial EFL at the d line the zoom was solved for (LensState::zoom).
        if (z["position"].is_null())
            std::printf("  zoom                 between positions, solved for a d-line EFL of %.4f mm\n",
                        z["nominal_focal_length_mm"].get<double>());
        else
            std::printf("  zoom                 %s (stated focal length %.2f mm)\n", z["position"].get<std::string>().c_str(),
                        z["nominal_focal_length_mm"].get<double>());
    }
    std::printf("  wavelength           %.2f nm\n", j["wavelength_nm"].get<double>());
    std::printf("  EFL                  %.4f mm\n", j["efl_mm"].get<double>());
    std::printf("  BFL                  %.4f mm\n", j["bfl_mm"].get<double>());
    std::printf("  front focal distance %.4f mm\n", j["front_focal_distance_mm"].get<double>());
    std::printf("  entrance pupil       %.4f mm diameter at z = %.4f mm\n",
                j["entrance_pupil_diameter_mm"].get<double>(), j["entrance_pupil_z_mm"].get<double>());
    std::printf("  exit pupil           %.4f mm diameter at z = %.4f mm\n",
                j["exit_pupil_diameter_mm"].get<double>(), j["exit_pupil_z_mm"].get<double>());
    std::printf("  f-number             %.3f (working %.3f)\n", j["f_number"].get<double>(),
                j["working_f_number"].get<double>());
    std::printf("  field of view        %.2f deg diagonal paraxial", j["field_of_view_deg"].get<double>());
    if (!j["real_field_of_view_deg"].is_null())
        std::printf(", %.2f deg real chief ray", j["real_field_of_view_deg"].get<double>());
    else if (j["real_field_of_view_beyond_180"].get<bool>())
        std::printf(", beyond 180 deg real (chief ray at 89.9 deg lands at %.3f mm)",
                    j["chief_ray_height_at_89_9_deg_mm"].get<double>());
    std::printf("\n  total track          %.4f mm\n", j["total_track_mm"].get<double>());
    std::printf("  surfaces             %d (%d reflecting)\n\n", j["surfaces"].get<int>(),
                j["reflecting_surfaces"].get<int>());
    std::printf("  %3s %12s %10s %9s %10s  %s\n", "#", "radius", "thickness", "index", "semi-ap", "material");
    for (const auto& row : j["surface_rows"]) {
        const std::string radius = row["stop"].get<bool>() ? "stop"
                                   : row["radius_mm"].is_null()
                                       ? "inf"
                                       : std::to_string(row["radius_mm"].get<double>());
        std::printf("  %3d %12s %10.4f %9.5f %10.4f  %s%s\n", row["number"].get<int>(), radius.c_str(),
                    row["thickness_mm"].get<double>(), row["index"].get<double>(),
                    row["semi_aperture_mm"].get<double>(), row["material"].get<std::string>().c_str(),
                    row["aspheric"].get<bool>() ? " [asphere]" : "");
    }
}

nlohmann::json libraryLensJson(const LibraryLens& lens) {
    nlohmann::json j = {{"id", lens.id},           {"maker", lens.maker},
                        {"model", lens.model},     {"name", lens.name},
                        {"kind", lens.kind},       {"tags", lens.tags},
                        {"focal_length_mm", lens.focalLengthMm},
                        {"focal_range_mm", {lens.focalMinMm, lens.focalMaxMm}},
                        {"f_number", lens.fNumber}, {"patent", lens.patent},
                        {"example", lens.example}, {"collection", lens.collection},
                        {"file", lens.path}};
    if (!lens.zoomPositions.empty()) {
        j["zoom_positions"] = lens.zoomPositions;
        j["zoom_focal_lengths_mm"] = lens.zoomFocalLengthsMm;
    }
    if (lens.zoomRangeMm)
        j["zoom_range_mm"] = {lens.zoomRangeMm->first, lens.zoomRangeMm->second};
    if (!lens.renamedFrom.empty()) j["renamed_from"] = lens.renamedFrom;
    return j;
}

// What the file can be set to: its EFL, or its zoom positions' focal lengths; a file that holds one
// state of a zoom says so.
std::string focalText(const LibraryLens& lens) {
    char buffer[160];
    if (!lens.zoomPositions.empty()) {
        std::string text;
        for (size_t i = 0; i < lens.zoomPositions.size(); ++i) {
            std::snprintf(buffer, sizeof buffer, "%s%.4g", i ? "/" : "", i < lens.zoomFocalLengthsMm.size() ? lens.zoomFocalLengthsMm[i] : 0.0);
            text += buffer;
        }
        return text + " mm";
    }
    std::snprintf(buffer, sizeof buffer, "%.4g mm", lens.focalLengthMm);
    return buffer;
}

void printLibraryLenses(const std::vector<const LibraryLens*>& lenses, bool json) {
    if (json) {
        nlohmann::json list = nlohmann::json::array();
        for (const LibraryLens* lens : lenses) list.push_back(libraryLensJson(*lens));
        std::cout << jsonText(nlohmann::json{{"lenses", list}}) << "\n";
        return;
    }
    for (const LibraryLens* lens : lenses) {
        std::string note;
        if (!lens->zoomPositions.empty()) {
            note = "  [zoom: ";
            for (size_t i = 0; i < lens->zoomPositions.size(); ++i) note += (i ? ", " : "") + lens->zoomPositions[i];
            note += "]";
        } else if (lens->zoomRangeMm) {
            char buffer[96];
            std::snprintf(buffer, sizeof buffer, "  [one state of the %g-%g mm zoom]", lens->zoomRangeMm->first,
                          lens->zoomRangeMm->second);
            note = buffer;
        }
        std::printf("%-60s %-22s f/%-5g %s%s\n", lens->id.c_str(), focalText(*lens).c_str(), lens->fNumber,
                    lens->name.c_str(), note.c_str());
    }
    std::printf("%zu lens%s\n", lenses.size(), lenses.size() == 1 ? "" : "es");
}

// "MIN-MAX", "MIN-" or "-MAX" (mm), or one focal length.
LibraryFilter focalRange(const std::string& text, LibraryFilter filter) {
    auto number = [&](const std::string& part) {
        size_t used = 0;
        double value = 0.0;
        try {
            value = std::stod(part, &used);
        } catch (const std::exception&) {
            used = 0;
        }
        if (used != part.size() || !(value > 0.0))
            throw CLI::ValidationError("--focal", "expected MIN-MAX in mm (e.g. 70-200), got '" + text + "'");
        return value;
    };
    const size_t dash = text.find('-');
    if (dash == std::string::npos) {
        filter.focalMinMm = filter.focalMaxMm = number(text);
    } else {
        if (dash > 0) filter.focalMinMm = number(text.substr(0, dash));
        if (dash + 1 < text.size()) filter.focalMaxMm = number(text.substr(dash + 1));
        if (!filter.focalMinMm && !filter.focalMaxMm)
            throw CLI::ValidationError("--focal", "expected MIN-MAX in mm (e.g. 70-200), got '" + text + "'");
        if (filter.focalMinMm && filter.focalMaxMm && *filter.focalMinMm > *filter.focalMaxMm)
            throw CLI::ValidationError("--focal", "MIN is above MAX in '" + text + "' (did you mean " +
                                                      text.substr(dash + 1) + "-" + text.substr(0, dash) + "?)");
    }
    return filter;
}

nlohmann::json checkJson(const std::string& lens, const LensCheckReport* report, const std::string& loadError) {
    nlohmann::json j = {{"lens", lens}, {"ok", report && report->ok()}};
    nlohmann::json failures = nlohmann::json::array();
    if (!report) failures.push_back({{"check", "load"}, {"zoom", ""}, {"detail", loadError}});
    if (report) {
        nlohmann::json positions = nlohmann::json::array();
        for (const LensCheckPosition& p : report->positions)
            positions.push_back({{"zoom", p.zoom},
                                 {"stated_focal_length_mm", p.statedFocalLengthMm > 0.0
                                                                ? nlohmann::json(p.statedFocalLengthMm)
                                                                : nlohmann::json(nullptr)},
                                 {"efl_mm", p.eflMm},
                                 {"wide_open_f_number", p.wideOpenFNumber},
                                 {"fan_f_number", p.fanFNumber > 0.0 ? nlohmann::json(p.fanFNumber)
                                                                     : nlohmann::json(nullptr)}});
        j["positions"] = positions;
        for (const LensCheckFailure& f : report->failures)
            failures.push_back({{"check", f.check}, {"zoom", f.zoom}, {"detail", f.detail}});
    }
    j["failures"] = failures;
    nlohmann::json notes = nlohmann::json::array();
    if (report)
        for (const LensCheckNote& n : report->notes) notes.push_back({{"check", n.check}, {"zoom", n.zoom}, {"detail", n.detail}});
    j["notes"] = notes;
    return j;
}

}  // namespace

void addLensCommands(CLI::App& app) {
    CLI::App* lens = app.add_subcommand("lens", "inspect a lens prescription");
    lens->require_subcommand(1);

    auto infoOptions = std::make_shared<LensOptions>();
    auto wavelength = std::make_shared<double>(kLineDNm);
    auto json = std::make_shared<bool>(false);
    CLI::App* info = lens->add_subcommand("info", "paraxial data and the surface table");
    addLensOptions(info, *infoOptions, kLensHelp);
    info->add_option("--wavelength", *wavelength, "wavelength in nm (default: d line 587.56)")
        ->check(CLI::Range(300.0, 2000.0));
    info->add_flag("--json", *json, "print one JSON object");
    info->callback([infoOptions, wavelength, json] {
        const LensPrescription prescription = loadLens(infoOptions->file);
        const LensSystem system = LensSystem::build(
            prescription, infoOptions->state());
        const nlohmann::json j = lensInfoJson(prescription, system, *wavelength);
        if (*json) std::cout << jsonText(j) << "\n";
        else printLensInfo(j);
    });

    auto filter = std::make_shared<LibraryFilter>();
    auto focal = std::make_shared<std::string>();
    auto listJson = std::make_shared<bool>(false);
    CLI::App* list = lens->add_subcommand("list", "the lenses of the library (docs/lens-library.md)");
    list->add_option("--maker", filter->maker, "only this maker (e.g. Nikon; case-insensitive)");
    list->add_option("--focal", *focal, "focal lengths MIN-MAX in mm: a lens whose EFL (or one of whose zoom positions, or the range between them) lies inside");
    list->add_option("--f-number", filter->maxFNumber, "only lenses at least this fast")->check(CLI::PositiveNumber);
    list->add_flag("--json", *listJson, "print one JSON object with a `lenses` array");
    list->callback([filter, focal, listJson] {
        const LibraryFilter f = focal->empty() ? *filter : focalRange(*focal, *filter);
        if (!f.maker.empty()) {
            const std::vector<std::string> makers = LensLibrary::shared().makers();
            const bool known = std::any_of(makers.begin(), makers.end(), [&](const std::string& m) {
                return m.size() == f.maker.size() && editDistance(m, f.maker) == 0;
            });
            if (!known) {
                std::string hint;
                for (const std::string& m : nearestNames(f.maker, makers, 5)) hint += (hint.empty() ? "" : ", ") + m;
                throw CLI::ValidationError("--maker", "no lens of maker '" + f.maker + "' in the library" +
                                                          (hint.empty() ? " (`flare lens list` names every lens and its maker)"
                                                                        : " (did you mean " + hint + "?)"));
            }
        }
        printLibraryLenses(LensLibrary::shared().filter(f), *listJson);
    });

    auto text = std::make_shared<std::vector<std::string>>();
    auto searchJson = std::make_shared<bool>(false);
    CLI::App* search = lens->add_subcommand("search", "library lenses whose id, maker, model, name or patent contain every word");
    search->add_option("TEXT", *text, "words to look for (e.g. 80-200 2.8)")->required();
    search->add_flag("--json", *searchJson, "print one JSON object with a `lenses` array");
    search->callback([text, searchJson] {
        std::string words;
        for (const std::string& w : *text) words += w + " ";
        printLibraryLenses(LensLibrary::shared().search(words), *searchJson);
    });

    auto checkLenses = std::make_shared<std::vector<std::string>>();
    auto checkJsonFlag = std::make_shared<bool>(false);
    CLI::App* check = lens->add_subcommand(
        "check", "the library's checks on lens files: load, EFL against the stated focal length, stop, axial ray fan");
    check->add_option("LENS", *checkLenses, kLensHelp)->required();
    check->add_flag("--json", *checkJsonFlag, "print one JSON object with a `lenses` array");
    check->callback([checkLenses, checkJsonFlag] {
        nlohmann::json all = nlohmann::json::array();
        int failed = 0;
        for (const std::string& name : *checkLenses) {
            nlohmann::json j;
            try {
                const LensCheckReport report = checkLens(loadLens(name));
                j = checkJson(name, &report, "");
            } catch (const InputError& e) {
                j = checkJson(name, nullptr, e.what());
            }
            failed += !j["ok"].get<bool>();
            if (!*checkJsonFlag) {
                std::printf("%s: %s\n", name.c_str(), j["ok"].get<bool>() ? "ok" : "FAILED");
                for (const auto& p : j["positions"]) {
                    const std::string zoom = p["zoom"].get<std::string>();
                    std::printf("  %sEFL %.3f mm", zoom.empty() ? "" : (zoom + ": ").c_str(), p["efl_mm"].get<double>());
                    if (!p["stated_focal_length_mm"].is_null())
                        std::printf(" (stated %.3f mm)", p["stated_focal_length_mm"].get<double>());
                    std::printf(", wide open f/%.3f", p["wide_open_f_number"].get<double>());
                    if (!p["fan_f_number"].is_null()) std::printf(", ray fan at f/%.3f", p["fan_f_number"].get<double>());
                    std::printf("\n");
                }
                auto line = [](const char* label, const nlohmann::json& f) {
                    const std::string zoom = f["zoom"].get<std::string>();
                    std::printf("  %s%s%s: %s\n", label, f["check"].get<std::string>().c_str(),
                                zoom.empty() ? "" : (" (" + zoom + ")").c_str(), f["detail"].get<std::string>().c_str());
                };
                for (const auto& f : j["failures"]) line("", f);
                for (const auto& n : j["notes"]) line("note: ", n);
            }
            all.push_back(std::move(j));
        }
        if (*checkJsonFlag) std::cout << jsonText(nlohmann::json{{"lenses", all}}) << "\n";
        // Failed checks are findings about the input: the input-error exit code.
        if (failed) throw CLI::RuntimeError(kExitInputError);
    });

    auto exportLens = std::make_shared<std::string>();
    auto exportOutput = std::make_shared<std::string>();
    auto utf16 = std::make_shared<bool>(false);
    CLI::App* exportCommand = lens->add_subcommand(
        "export", "write the prescription as a Zemax OpticStudio .zmx file (every zoom position a configuration)");
    exportCommand->add_option("LENS", *exportLens, kLensHelp)->required();
    exportCommand->add_option("-o,--output", *exportOutput, ".zmx file to write")->required();
    exportCommand->add_flag("--utf16", *utf16, "write UTF-16 with a byte-order mark, as OpticStudio does (default: ASCII/UTF-8)");
    exportCommand->callback([exportLens, exportOutput, utf16] {
        const std::string& out = *exportOutput;
        std::string extension = out.size() >= 4 ? out.substr(out.size() - 4) : "";
        for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
        if (extension != ".zmx") throw InputError(out, 0, "the output must be a .zmx file");
        OutputFiles outputs;
        outputs.add(out, "-o");
        const std::string text = writeZemax(loadLens(*exportLens));
        outputs.write(out, *utf16 ? encodeUtf16Le(text) : text);
        outputs.commit();
        std::printf("wrote %s\n", out.c_str());
    });

    auto drawOptions = std::make_shared<LensOptions>();
    auto output = std::make_shared<std::string>();
    auto rays = std::make_shared<int>(9);
    auto field = std::make_shared<std::optional<double>>();
    auto ghost = std::make_shared<std::vector<int>>();
    CLI::App* draw = lens->add_subcommand("draw", "SVG cutaway of the lens with traced ray fans");
    addLensOptions(draw, *drawOptions, kLensHelp);
    draw->add_option("-o,--output", *output, "SVG file to write")->required();
    draw->add_option("--rays", *rays, "rays per field fan")->check(CLI::Range(1, 1000));
    draw->add_option("--field", *field, "off-axis field angle in degrees (default: the sensor's half width)")
        ->check(CLI::Range(-89.0, 89.0));
    draw->add_option("--ghost", *ghost, "draw this ghost's ray paths: its reflecting surfaces, 1-based, the sensor being "
                                       "surfaces+1 (two in either order, e.g. 3,7 or 7,3; four in the order the light "
                                       "meets them)")
        ->delimiter(',')
        ->expected(2, 4);
    draw->callback([drawOptions, output, rays, field, ghost] {
        OutputFiles outputs;
        outputs.add(*output, "-o");
        const LensSystem system = buildLens(*drawOptions);
        LensDrawingOptions options;
        options.raysPerField = *rays;
        double fieldDeg = 0.0;
        if (field->has_value()) {
            fieldDeg = **field;
        } else {
            const ParaxialData para = analyseParaxial(system, kLineDNm);
            fieldDeg = std::atan(0.5 * system.sensor().widthMm / std::abs(para.eflMm)) * 180.0 / M_PI;
            fieldDeg = std::min(fieldDeg, 80.0);
        }
        options.fieldsDeg = {0.0};
        if (fieldDeg != 0.0) options.fieldsDeg.push_back(fieldDeg);
        std::vector<DrawnRay> fans;
        if (ghost->empty()) {
            fans = traceRayFans(system, options);
        } else {
            std::vector<int> reflections;
            for (int number : *ghost) {
                const int index = number - 1;
                const bool sensor = index == system.surfaceCount();
                if (index < 0 || index > system.surfaceCount() || (!sensor && !system.isReflecting(index)))
                    throw InputError(drawOptions->file, 0,
                                     "--ghost: surface " + std::to_string(number) + " is not a reflecting surface");
                reflections.push_back(index);
            }
            // Two reflections can only be met in one order (the farther surface first), so either
            // order names the same ghost; `flare ghosts` prints it as met (e.g. 7-3).
            if (reflections.size() == 2 && reflections[0] < reflections[1]) std::swap(reflections[0], reflections[1]);
            const std::vector<GhostPath> valid = enumerateGhosts(system, static_cast<int>(reflections.size()), true);
            if (std::find(valid.begin(), valid.end(), GhostPath{reflections}) == valid.end())
                throw InputError(drawOptions->file, 0,
                                 "--ghost: not a ghost path (after each reflection the light must travel back to a surface in front of it)");
            options.fieldsDeg = {field->value_or(0.0)};
            std::string surfaces;
            for (int index : reflections) surfaces += (surfaces.empty() ? "" : "-") + std::to_string(index + 1);
            options.title = system.name() + ", ghost " + surfaces;
            fans = traceRayFans(system, LensDrawingOptions{1, {options.fieldsDeg[0]}, options.wavelengthNm, ""});
            for (DrawnRay& r : traceGhostRays(system, reflections, options.fieldsDeg[0], *rays, options.wavelengthNm))
                fans.push_back(std::move(r));
        }
        outputs.write(*output, drawLensSvg(system, fans, options));
        outputs.commit();
        std::printf("wrote %s (%zu rays)\n", output->c_str(), fans.size());
    });
}

}  // namespace flare::cli
