// trial_csv_stream <urdf> <data.csv>: stream a trial CSV through ForEachTrial (progress on a
// terminal) and print the row count and the mean measured force; used to measure the reader's
// peak memory on large files (/usr/bin/time -v, docs/reliability.md).

#include <iostream>

#include "isowrench/error.hpp"
#include "isowrench/model.hpp"
#include "isowrench/trial_csv.hpp"

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: trial_csv_stream <urdf> <data.csv>\n";
    return 2;
  }
  try {
    isowrench::Model model = isowrench::Model::FromUrdfFile(argv[1]);
    isowrench::Vector6d sum = isowrench::Vector6d::Zero();
    long rows = isowrench::ForEachTrial(
        model, argv[2], [&](const isowrench::Trial& t) { sum += t.wrench; },
        isowrench::TerminalProgress(argv[2]));
    std::cout << rows << " trials, mean wrench [" << (sum / static_cast<double>(rows)).transpose()
              << "] N, N·m\n";
  } catch (const isowrench::Error& e) {
    std::cerr << "trial_csv_stream: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
