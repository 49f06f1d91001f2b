// What identifies the running build of penumbra, for on-disk caches (the reference cache,
// the map cache): an entry written by another build is never trusted. And what identifies
// the machine, for the times a cache keeps (a time is only compared with times of the same
// machine).
#pragma once

#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

namespace penumbra {

// {"path", "size", "mtime"} of a file, or {"path", "missing": true}.
nlohmann::json file_identity(const std::filesystem::path& p);

// The identity of the file holding this code: the penumbra executable, or the Python
// module's shared library when the module renders (then /proc/self/exe is the Python
// interpreter, which does not change when penumbra is rebuilt).
nlohmann::json program_identity();

// The processor's model name (/proc/cpuinfo), or "unknown".
std::string cpu_model();
// The machine a time is measured on: "HOST / CPU model / N logical cores".
std::string machine_identity();

}  // namespace penumbra
