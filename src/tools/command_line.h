// The command line of the tools: parsing with Boost.Program_options, --help, and the exit codes
// a tool ends with when it does not run (0 after --help, 2 after a usage error).
#pragma once

#include <exception>
#include <iostream>
#include <optional>
#include <string>

#include <boost/program_options.hpp>

namespace ccir_mapping::tools {

/// Parses argv into the variables `options` names; nullopt to go on, else the exit code: 0 once
/// --help printed the options, 2 once a parse error (or a required option missing) was printed.
inline std::optional<int> parseCommandLine(
    const std::string& tool, const boost::program_options::options_description& options, int argc,
    char** argv, boost::program_options::variables_map* parsed = nullptr) {
  namespace po = boost::program_options;
  po::variables_map arguments;
  try {
    po::store(po::parse_command_line(argc, argv, options), arguments);
    if (arguments.count("help")) {
      std::cout << options << '\n';
      return 0;
    }
    po::notify(arguments);
  } catch (const po::error& e) {
    std::cerr << tool << ": " << e.what() << "\n" << options << '\n';
    return 2;
  }
  if (parsed) *parsed = std::move(arguments);
  return std::nullopt;
}

/// A tool's main: parses the options into an Options (or ends with the exit code `parse`
/// gives), runs and reports; an exception is printed as "<tool>: <what>" and ends with 1.
template <class Options, class Run, class Report>
int runTool(const std::string& tool, int argc, char** argv,
            std::optional<int> (*parse)(int, char**, Options*), Run run, Report report) {
  Options options;
  if (const auto exit_code = parse(argc, argv, &options)) return *exit_code;
  try {
    report(options, run(options));
  } catch (const std::exception& e) {
    std::cerr << tool << ": " << e.what() << '\n';
    return 1;
  }
  return 0;
}

/// Prints "<tool>: <message>" and returns the exit code of a usage error (2).
inline int usageError(const std::string& tool, const std::string& message) {
  std::cerr << tool << ": " << message << '\n';
  return 2;
}

}  // namespace ccir_mapping::tools
