// A main for the fuzz targets when libFuzzer is not available (e.g. g++): runs
// LLVMFuzzerTestOneInput once per input file, so that corpora and crash reproducers replay with
// any compiler. Arguments are files or directories (all regular files in them, in name order);
// with none, standard input is the one input. Options libFuzzer would take ("-runs=...") are
// ignored.
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size);

namespace {

void run(const std::string& bytes) {
    LLVMFuzzerTestOneInput(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size());
}

}  // namespace

int main(int argc, char** argv) {
    namespace fs = std::filesystem;
    std::vector<fs::path> inputs;
    for (int i = 1; i < argc; ++i) {
        const fs::path arg = argv[i];
        if (argv[i][0] == '-') continue;
        std::error_code ec;
        if (!fs::is_directory(arg, ec)) {
            inputs.push_back(arg);
            continue;
        }
        std::vector<fs::path> files;
        for (const auto& entry : fs::directory_iterator(arg, ec)) {
            if (entry.is_regular_file()) files.push_back(entry.path());
        }
        std::sort(files.begin(), files.end());
        inputs.insert(inputs.end(), files.begin(), files.end());
    }
    if (argc == 1) {
        run(std::string(std::istreambuf_iterator<char>(std::cin), {}));
        std::printf("ran 1 input from standard input\n");
        return 0;
    }
    for (const fs::path& path : inputs) {
        std::ifstream in(path, std::ios::binary);
        if (!in) {
            std::fprintf(stderr, "%s: cannot open\n", path.c_str());
            return 1;
        }
        std::fprintf(stderr, "running %s\n", path.c_str());
        run(std::string(std::istreambuf_iterator<char>(in), {}));
    }
    std::printf("ran %zu inputs\n", inputs.size());
    return 0;
}
