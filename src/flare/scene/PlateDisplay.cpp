#include "flare/scene/PlateDisplay.h"

#include <cstdlib>

#include <OpenColorIO/OpenColorIO.h>

#include "flare/core/Error.h"

namespace OCIO = OCIO_NAMESPACE;

namespace flare {

namespace {

OCIO::ConstConfigRcPtr configFromEnv(const std::string& optionName) {
    const char* env = std::getenv("OCIO");
    if (!env || !*env)
        throw InputError(optionName, 0, "a display and view come from an OpenColorIO config: set $OCIO to one");
    try {
        return OCIO::Config::CreateFromEnv();
    } catch (const OCIO::Exception& e) {
        throw InputError(env, 0, std::string("the OpenColorIO config ($OCIO) cannot be read: ") + e.what());
    }
}

std::string displaysOf(const OCIO::ConstConfigRcPtr& config) {
    std::string out;
    for (int d = 0; d < config->getNumDisplays(); ++d) {
        const char* display = config->getDisplay(d);
        out += (d ? "; " : "") + std::string(display) + ":";
        for (int v = 0; v < config->getNumViews(display); ++v) out += (v ? ", " : " ") + std::string(config->getView(display, v));
    }
    return out.empty() ? "none" : out;
}

}  // namespace

ImageLayer applyDisplayView(const ImageLayer& image, const PlateColourSpace& space, const DisplayView& displayView,
                            double exposure, const std::string& optionName) {
    const OCIO::ConstConfigRcPtr config = configFromEnv(optionName);
    bool knownDisplay = false;
    for (int d = 0; d < config->getNumDisplays(); ++d) knownDisplay |= displayView.display == config->getDisplay(d);
    if (!knownDisplay)
        throw InputError(optionName, 0, "the OpenColorIO config has no display '" + displayView.display +
                                            "' (displays and views: " + displaysOf(config) + ")");
    const std::string view =
        displayView.view.empty() ? std::string(config->getDefaultView(displayView.display.c_str())) : displayView.view;
    bool knownView = false;
    for (int v = 0; v < config->getNumViews(displayView.display.c_str()); ++v)
        knownView |= view == config->getView(displayView.display.c_str(), v);
    if (!knownView)
        throw InputError("--view", 0, "the display '" + displayView.display + "' of the OpenColorIO config has no view '" +
                                          view + "' (displays and views: " + displaysOf(config) + ")");
    // From XYZ, or from ACES2065-1 (AP0) when the config relates its spaces to that instead.
    const bool xyzRole = config->hasRole("cie_xyz_d65_interchange");
    if (!xyzRole && !config->hasRole("aces_interchange"))
        throw InputError(optionName, 0, "the OpenColorIO config has neither a cie_xyz_d65_interchange nor an "
                                        "aces_interchange role to start the view from");
    const glm::dmat3 toSource =
        (xyzRole ? glm::dmat3(1.0) : resolveColourSpace("ACES2065-1", optionName).fromXyz) * space.toXyz * exposure;
    OCIO::ConstCPUProcessorRcPtr cpu;
    try {
        OCIO::DisplayViewTransformRcPtr transform = OCIO::DisplayViewTransform::Create();
        transform->setSrc(xyzRole ? "cie_xyz_d65_interchange" : "aces_interchange");
        transform->setDisplay(displayView.display.c_str());
        transform->setView(view.c_str());
        cpu = config->getProcessor(transform)->getDefaultCPUProcessor();
    } catch (const OCIO::Exception& e) {
        throw InputError(optionName, 0, "OpenColorIO cannot show '" + displayView.display + "' / '" + view + "': " + e.what());
    }
    ImageLayer out = image;
    for (size_t i = 0; i < out.rgb.size(); i += 3) {
        const glm::dvec3 source = toSource * glm::dvec3(image.rgb[i], image.rgb[i + 1], image.rgb[i + 2]);
        float p[3] = {static_cast<float>(source.x), static_cast<float>(source.y), static_cast<float>(source.z)};
        cpu->applyRGB(p);
        for (int k = 0; k < 3; ++k) out.rgb[i + k] = p[k];
    }
    return out;
}

}  // namespace flare
