// Shared plumbing of the tesswave subcommands: output checks, messages, JSON printing.
#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

namespace tesswave::cli {

// Refuses to overwrite an existing output unless -y was given (as FFmpeg does), and refuses an
// output that is also an input.
void check_output(const std::string& path, bool overwrite,
                  const std::vector<std::string>& inputs = {});

// "WxH" or "W x H" into two positive numbers; throws Error naming the option.
std::pair<double, double> parse_size(const std::string& text, const std::string& option);
std::pair<int, int> parse_cells(const std::string& text, const std::string& option);

// Registers each subcommand on the app.
void add_mesh_commands(CLI::App& app);
void add_demo_command(CLI::App& app);

}  // namespace tesswave::cli
