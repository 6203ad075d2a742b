#pragma once
/// A process-wide stop request for long calls into libraries that run no code of ours but offer a
/// progress callback of their own (GDAL's GeoTIFF writer: seconds of LZMA compression). The CLI
/// installs its Ctrl-C flag here; such callbacks return "stop" when it is set, and the call ends
/// with Cancelled (exit 130) and no output.
#include <functional>

namespace terracl {

/// Installs `check` (called from the thread that runs the library call; it must be cheap and must
/// not throw). An empty function removes it.
void set_stop_check(std::function<bool()> check);

/// True when the installed check asks to stop; false when none is installed.
bool stop_requested();

}  // namespace terracl
