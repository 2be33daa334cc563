// Runs a fuzz target once per input file, for the builds without libFuzzer (GCC, the ARM builds):
// ctest replays the committed corpus (tests/fuzz/corpus/<target>/: seeds, and every input that
// once broke an invariant) through the same LLVMFuzzerTestOneInput the coverage-guided fuzzer
// drives. An input that breaks an invariant aborts inside the target.
//
//   fuzz_<target> FILE|DIR...     (a folder: every regular file in it, in name order)
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size);

int main(int argc, char** argv) {
  namespace fs = std::filesystem;
  std::vector<fs::path> inputs;
  for (int i = 1; i < argc; ++i) {
    std::error_code ec;
    if (fs::is_directory(argv[i], ec)) {
      for (const auto& e : fs::directory_iterator(argv[i], ec))
        if (e.is_regular_file()) inputs.push_back(e.path());
    } else if (fs::is_regular_file(argv[i], ec)) {
      inputs.emplace_back(argv[i]);
    } else {
      std::fprintf(stderr, "%s: no such file or folder\n", argv[i]);
      return 2;
    }
  }
  std::sort(inputs.begin(), inputs.end());
  if (inputs.empty()) {  // a wrong path must not pass as "nothing failed"
    std::fprintf(stderr, "%s: no inputs given (usage: %s FILE|DIR...)\n", argv[0], argv[0]);
    return 2;
  }
  for (const fs::path& p : inputs) {
    std::ifstream f(p, std::ios::binary);
    const std::vector<char> bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    if (!f.good() && !f.eof()) {
      std::fprintf(stderr, "%s: cannot read\n", p.c_str());
      return 2;
    }
    std::fprintf(stderr, "replay %s (%zu bytes)\n", p.c_str(), bytes.size());
    LLVMFuzzerTestOneInput(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size());
  }
  std::printf("%s: %zu input%s replayed, every invariant held\n", argv[0], inputs.size(), inputs.size() == 1 ? "" : "s");
  return 0;
}
