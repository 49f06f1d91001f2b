// Subcommands of the `penumbra` tool register themselves from their own source file
// (cmd_render.cpp, cmd_compare.cpp, ...), so adding one touches no shared file. Each
// registration object is named after its command (`const CommandRegistration render_command`):
// the unity build (PENUMBRA_UNITY_BUILD) compiles several command files as one.
#pragma once

#include <functional>
#include <string>

#include <CLI/CLI.hpp>

namespace penumbra::app {

// `setup` adds the subcommand and its options to `app` and returns the function to run
// when it was chosen; that function returns the process exit code.
using CommandSetup = std::function<std::function<int()>(CLI::App& app)>;

struct CommandRegistration {
  CommandRegistration(std::string name, int order, CommandSetup setup);
};

// Used by main(): every registered command, in `order`.
void setup_commands(CLI::App& app, std::vector<std::pair<CLI::App*, std::function<int()>>>* out);

}  // namespace penumbra::app
