// SPDX-License-Identifier: Apache-2.0
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

/// Adds a further check beside the installed one, for a component that lives shorter than the
/// process (a studio server's cancel and time budget); returns its id for remove_stop_check.
int add_stop_check(std::function<bool()> check);
void remove_stop_check(int id);

/// True when the installed check or an added one asks to stop; false when none does, or on a
/// thread inside a NoStopScope.
bool stop_requested();

/// While one is alive on a thread, stop_requested() is false there: for work that restores a
/// consistent state after a stop (a studio session going back to its previous script) and must
/// not itself be stopped half-way.
class NoStopScope {
 public:
  NoStopScope();
  ~NoStopScope();
  NoStopScope(const NoStopScope&) = delete;
  NoStopScope& operator=(const NoStopScope&) = delete;
};

}  // namespace terracl
