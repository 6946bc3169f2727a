// Warnings: problems the engine works around with a stated fallback (an unknown Zemax keyword, a
// coating it cannot model, ...) rather than refusing the input. By default each is printed on
// stderr as "flare: warning: TEXT", which suits the CLI; a caller that reports them its own way
// (the Python module, through Python's `warnings`) captures them instead.
#pragma once

#include <string>
#include <vector>

namespace flare {

// Reports a warning ("file:line: problem" when it concerns a file): to the innermost
// WarningCapture alive on this thread, else on stderr.
void warn(const std::string& text);

// While alive, collects the warnings raised on the thread that made it (the engine raises them
// while reading inputs, on the calling thread). Captures nest: the innermost one collects.
class WarningCapture {
public:
    WarningCapture();
    ~WarningCapture();
    WarningCapture(const WarningCapture&) = delete;
    WarningCapture& operator=(const WarningCapture&) = delete;

    // The warnings collected so far, in order; the capture is emptied.
    std::vector<std::string> take();

private:
    friend void warn(const std::string& text);
    std::vector<std::string> warnings_;
    WarningCapture* outer_;
};

}  // namespace flare
