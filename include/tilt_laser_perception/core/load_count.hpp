// How often each nodelet was loaded in this process, and how long the process
// has run: what a nodelet's diagnostics say about restarts. Kept in the
// process (not on the parameter server, which outlives it and other runs): a
// nodelet unloaded and loaded again in the same manager counts 2; a manager
// that died and was respawned is a new process, which its uptime shows.
#pragma once

#include <string>

namespace tilt_laser_perception {
namespace core {

/// Counts one more load of the nodelet `name` in this process; returns the count (1 the first time). Thread-safe.
int countLoad(const std::string& name);

/// Seconds since this process started (since the library was loaded into it), on the steady clock.
double processUptime();

}  // namespace core
}  // namespace tilt_laser_perception
