// isowrench command-line tool: a thin layer over the library. Every command is a file
// src/cli/<name>_command.cpp that registers itself (see command.hpp).

#include <algorithm>
#include <clocale>
#include <iostream>

#include "cli/command.hpp"
#include "isowrench/error.hpp"
#include "isowrench/input_checks.hpp"
#include "isowrench/io.hpp"

namespace {

// Documented in README.md "Exit codes"; each code has a CTest case (tests/cli).
const char* kExitCodes =
    "Exit codes:\n"
    "  0  success\n"
    "  1  bad input: a file, option value, model or data the command cannot use (message on "
    "stderr)\n"
    "  2  command-line usage error: unknown option or subcommand, missing or malformed argument\n"
    "  3  internal error (a bug in isowrench; please report it with the command line)\n"
    "  4  no equilibrium: the muscle torque drives a self-motion (wrench); the output says which";

}  // namespace

int main(int argc, char** argv) {
  std::setlocale(LC_ALL, "C");
  CLI::App app{
      "isowrench: the wrench a stimulated muscle produces at a limb endpoint bolted to a 6-axis "
      "force/torque transducer, with transducer, base and joint compliances (Eq. 10 of the "
      "seed paper). Units: SI; postures in degrees. Docs: README.md, docs/."};
  app.require_subcommand(1);
  app.footer(kExitCodes);
  app.set_version_flag("--version", "isowrench 0.1.0");
  auto commands = isowrench::cli::RegisteredCommands();
  std::sort(commands.begin(), commands.end(), [](const auto& a, const auto& b) {
    return a.order < b.order || (a.order == b.order && a.name < b.name);
  });
  // An unknown command is a usage error, also with --help (CLI11 would print the main help and
  // exit 0): the first argument that is not an option names the command.
  if (argc > 1 && argv[1][0] != '-') {
    const std::string name = argv[1];
    std::vector<std::string> names;
    for (const auto& command : commands) names.push_back(command.name);
    if (std::find(names.begin(), names.end(), name) == names.end()) {
      std::cerr << "isowrench: error: unknown command '" << name << "'"
                << isowrench::DidYouMean(name, names) << "; the commands are "
                << isowrench::util::Join(names, ", ") << " (isowrench --help)\n";
      return 2;
    }
  }
  std::vector<std::pair<CLI::App*, std::function<int()>>> runners;
  for (const auto& command : commands) {
    CLI::App* sub = app.add_subcommand(command.name, command.description);
    sub->footer(kExitCodes);
    runners.emplace_back(sub, command.setup(*sub));
    // A list option takes one argument per occurrence (items comma-separated, or the option
    // repeated): CLI11's default for vectors would also take the tokens after it, so that
    // `fit m.urdf --lock knee_rx data.csv` read the data file as a coordinate.
    for (CLI::Option* option : sub->get_options()) {
      if (option->get_items_expected_max() > 1) option->allow_extra_args(false);
    }
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version exit 0; every usage error exits 2 (CLI11's own codes vary).
    return app.exit(e) == 0 ? 0 : 2;
  }
  try {
    for (auto& [sub, run] : runners) {
      if (sub->parsed()) return run();
    }
  } catch (const isowrench::Error& e) {
    std::cerr << "isowrench: error: " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "isowrench: internal error: " << e.what() << "\n";
    return 3;
  }
  return 0;
}
