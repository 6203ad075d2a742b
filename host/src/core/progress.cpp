// SPDX-License-Identifier: Apache-2.0
#include <terracl/error.hpp>
#include <terracl/interrupt.hpp>
#include <terracl/progress.hpp>

#include <algorithm>
#include <map>
#include <mutex>

namespace terracl {

namespace {
std::function<bool()>& stop_check() {
  static std::function<bool()> check;
  return check;
}
thread_local int no_stop_depth = 0;
struct AddedChecks {
  std::mutex mutex;
  std::map<int, std::function<bool()>> checks;
  int next = 0;
};
AddedChecks& added() {
  static AddedChecks a;
  return a;
}

}  // namespace

void set_stop_check(std::function<bool()> check) { stop_check() = std::move(check); }

int add_stop_check(std::function<bool()> check) {
  AddedChecks& a = added();
  std::lock_guard<std::mutex> lock(a.mutex);
  a.checks[a.next] = std::move(check);
  return a.next++;
}

void remove_stop_check(int id) {
  AddedChecks& a = added();
  std::lock_guard<std::mutex> lock(a.mutex);
  a.checks.erase(id);
}

bool stop_requested() {
  if (no_stop_depth > 0) return false;
  if (stop_check() && stop_check()()) return true;
  AddedChecks& a = added();
  std::lock_guard<std::mutex> lock(a.mutex);
  for (const auto& [id, check] : a.checks)
    if (check()) return true;
  return false;
}


NoStopScope::NoStopScope() { ++no_stop_depth; }
NoStopScope::~NoStopScope() { --no_stop_depth; }

void report_progress(const Progress& p, const std::string& stage, double fraction, const std::string& message) {
  if (p && !p(std::clamp(fraction, 0.0, 1.0), message)) throw Cancelled(stage);
}

Progress scaled_progress(const Progress& parent, double begin, double end) {
  if (!parent) return {};
  return [parent, begin, end](double f, const std::string& m) { return parent(begin + (end - begin) * f, m); };
}

}  // namespace terracl
