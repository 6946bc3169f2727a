#include "flare/core/Warnings.h"

#include <cstdio>
#include <utility>

namespace flare {

namespace {
// Per thread: a capture on one Python thread must not swallow another thread's warnings.
thread_local WarningCapture* tInnermost = nullptr;
}  // namespace

void warn(const std::string& text) {
    if (tInnermost) tInnermost->warnings_.push_back(text);
    else std::fprintf(stderr, "flare: warning: %s\n", text.c_str());
}

WarningCapture::WarningCapture() : outer_(tInnermost) { tInnermost = this; }

WarningCapture::~WarningCapture() { tInnermost = outer_; }

std::vector<std::string> WarningCapture::take() { return std::exchange(warnings_, {}); }

}  // namespace flare
