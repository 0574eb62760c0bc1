// The tesswave command: one subcommand per job, thin over the libraries. Errors become one line
// on stderr and a non-zero exit code.
#include <signal.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <new>
#include <string>
#include <vector>

#include "cli.h"
#include "core/io/file_io.h"
#include "core/math/error.h"
#include "core/math/heap.h"
#include "core/math/parallel.h"
#include "core/math/strings.h"

namespace {

volatile sig_atomic_t stderr_is_terminal = 0;  // read by the signal handler

// SIGINT and SIGTERM: remove what this run wrote (temporaries, committed outputs, folders it
// made), say so in one line and exit 130 or 143. A second signal during that exits at once.
extern "C" void on_interrupt(int signal_number) {
    static volatile sig_atomic_t handling = 0;
    if (handling) ::_exit(128 + signal_number);
    handling = 1;
    tesswave::remove_run_outputs();
    // On a terminal the message starts a line of its own (a progress bar may be half drawn).
    static const char message[] = "\ntesswave: interrupted; removed the partial outputs\n";
    const int skip = stderr_is_terminal ? 0 : 1;
    const ssize_t ignored = ::write(2, message + skip, sizeof message - 1 - skip);
    (void)ignored;
    ::_exit(128 + signal_number);
}

void install_interrupt_handlers() {
    stderr_is_terminal = ::isatty(2) ? 1 : 0;
    struct sigaction action {};
    action.sa_handler = on_interrupt;
    sigemptyset(&action.sa_mask);
    action.sa_flags = SA_NODEFER;  // a second signal re-enters and exits at once
    sigaction(SIGINT, &action, nullptr);
    sigaction(SIGTERM, &action, nullptr);
}

// Messages from libraries (OpenImageIO, libpng) can span lines; the command prints one line.
std::string one_line(std::string text) {
    std::string out;
    for (char c : text) {
        if (c == '\n' || c == '\r') {
            if (!out.empty() && out.back() != ' ') out += "; ";
        } else {
            out += c;
        }
    }
    while (!out.empty() && (out.back() == ' ' || out.back() == ';')) out.pop_back();
    return out;
}

// The first positional argument of the deepest subcommand that ran (its input file, in every
// command that reads one): what an out-of-memory message names.
std::string first_positional(const CLI::App& app) {
    for (const CLI::App* sub : app.get_subcommands()) {
        const std::string deeper = first_positional(*sub);
        if (!deeper.empty()) return deeper;
        for (const CLI::Option* o : sub->get_options()) {
            if (o->get_positional() && o->count() > 0) return o->results().front();
        }
    }
    return {};
}

// Every floating-point option refuses NaN (exit 2, naming the option): CLI11's ranges let it pass,
// since every comparison with it is false, and it then stood for a default or broke the work.
void refuse_nan(CLI::App& app) {
    const CLI::Validator not_nan(
        [](std::string& value) -> std::string {
            size_t from = 0;
            for (;;) {
                const size_t to = value.find(',', from);
                const std::string piece = value.substr(from, to - from);
                char* end = nullptr;
                const double v = std::strtod(piece.c_str(), &end);
                if (end != piece.c_str() && *end == 0 && std::isnan(v)) {
                    return piece + " is not a number";
                }
                if (to == std::string::npos) return {};
                from = to + 1;
            }
        },
        "");
    for (CLI::Option* o : app.get_options()) {
        if (o->get_type_name().rfind("FLOAT", 0) == 0) o->check(not_nan);
    }
    for (CLI::App* sub : app.get_subcommands({})) refuse_nan(*sub);
}

// The subcommand a mistyped name was meant to be: the one fewest edits away (at most 3).
std::string nearest_command(const CLI::App& app, const std::string& typed) {
    std::string best;
    size_t best_distance = 4;
    for (const CLI::App* sub : app.get_subcommands([](const CLI::App*) { return true; })) {
        const std::string& name = sub->get_name();
        std::vector<size_t> row(name.size() + 1);
        for (size_t j = 0; j <= name.size(); ++j) row[j] = j;
        for (size_t i = 1; i <= typed.size(); ++i) {
            size_t diagonal = row[0];
            row[0] = i;
            for (size_t j = 1; j <= name.size(); ++j) {
                const size_t up = row[j];
                row[j] = std::min(
                    {row[j] + 1, row[j - 1] + 1, diagonal + (typed[i - 1] == name[j - 1] ? 0 : 1)});
                diagonal = up;
            }
        }
        if (row[name.size()] < best_distance) best = name, best_distance = row[name.size()];
    }
    return best;
}

// A word where a subcommand goes that names none: "unknown command" (CLI11 says only that a
// subcommand is required). `app` is the top level or a group of subcommands (mesh).
void check_command_name(const CLI::App& app, int argc, char** argv, int from) {
    for (int i = from; i < argc; ++i) {
        const std::string arg = argv[i];
        if (arg == "--threads") ++i;  // its value
        if (arg.empty() || arg[0] == '-') continue;
        const CLI::App* sub = nullptr;
        for (const CLI::App* s : app.get_subcommands([](const CLI::App*) { return true; })) {
            if (s->get_name() == arg) sub = s;
        }
        if (!sub) {
            const std::string near = nearest_command(app, arg);
            throw CLI::ValidationError(
                tesswave::str("unknown command '", arg, "'",
                              near.empty() ? "" : tesswave::str(" (did you mean '", near, "'?)")));
        }
        if (!sub->get_subcommands([](const CLI::App*) { return true; }).empty()) {
            check_command_name(*sub, argc, argv, i + 1);
        }
        return;
    }
}

}  // namespace

int main(int argc, char** argv) {
    tesswave::keep_freed_blocks();
    CLI::App app{
        "tesswave: images on deformable planar tessellations, analysed with the lifted bilinear "
        "wavelet transform (Bertram et al., \"Wavelets on Planar Tesselations\")."};
    app.set_version_flag("--version", "tesswave 0.1.0");
    app.require_subcommand(1);
    // -q and -v belong to every subcommand: they may come before or after its name.
    app.fallthrough(true);
    bool quiet = false, verbose = false;
    auto* q =
        app.add_flag("-q,--quiet", quiet,
                     "Errors only (and --json output): no progress, notes, warnings or summary");
    app.add_flag("-v,--verbose", verbose, "Each stage on a line of its own, with its time")
        ->excludes(q);
    // Known before any subcommand runs (CLI11 runs their callbacks while parsing).
    for (int i = 1; i < argc; ++i) {
        const std::string arg = argv[i];
        if (arg == "-q" || arg == "--quiet") quiet = true;
        if (arg == "-v" || arg == "--verbose") verbose = true;
    }
    int threads = 0;
    app.add_option("--threads", threads,
                   "Threads to use (default 0: all cores); output is the same")
        ->check(CLI::Range(0, 256));
    // Also known before any subcommand runs; CLI11 checks the value as it parses.
    for (int i = 1; i < argc; ++i) {
        const std::string arg = argv[i];
        const std::string value = arg.rfind("--threads=", 0) == 0      ? arg.substr(10)
                                  : arg == "--threads" && i + 1 < argc ? argv[i + 1]
                                                                       : std::string();
        char* end = nullptr;
        const long n = value.empty() ? -1 : std::strtol(value.c_str(), &end, 10);
        if (end && *end == 0 && n >= 0 && n <= 256) tesswave::set_thread_count(static_cast<int>(n));
    }
    bool json = false;
    for (int i = 1; i < argc; ++i) json = json || std::string(argv[i]) == "--json";
    if (quiet && !verbose) {
        tesswave::cli::verbosity() = tesswave::cli::Verbosity::quiet;
        if (!json && std::freopen("/dev/null", "w", stdout) == nullptr) return 1;
    } else if (verbose && !quiet) {
        tesswave::cli::verbosity() = tesswave::cli::Verbosity::verbose;
    }
    tesswave::cli::add_mesh_commands(app);
    tesswave::cli::add_analyze_command(app);
    tesswave::cli::add_codec_commands(app);
    tesswave::cli::add_compare_command(app);
    tesswave::cli::add_compare_video_command(app);
    tesswave::cli::add_morph_commands(app);
    tesswave::cli::add_eval_interp_command(app);
    tesswave::cli::add_video_commands(app);
    tesswave::cli::add_info_command(app);
    tesswave::cli::add_samples_command(app);
    tesswave::cli::add_demo_command(app);
    refuse_nan(app);
    install_interrupt_handlers();
    try {
        check_command_name(app, argc, argv, 1);
        app.parse(argc, argv);
        tesswave::keep_run_outputs();  // complete: what the run wrote stays
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForVersion& e) {
        return app.exit(e);
    } catch (const CLI::RuntimeError& e) {
        return e.get_exit_code();  // the command printed its own messages
    } catch (const CLI::ParseError& e) {
        std::fprintf(stderr, "tesswave: %s (see --help)\n", e.what());
        return 2;
    } catch (const tesswave::Error& e) {
        tesswave::remove_run_outputs();  // a failed run leaves nothing it wrote
        std::fprintf(stderr, "tesswave: %s\n", one_line(e.what()).c_str());
        return 1;
    } catch (const std::bad_alloc&) {
        tesswave::remove_run_outputs();
        const std::string input = first_positional(app);
        std::fprintf(stderr, "tesswave: %sout of memory\n",
                     input.empty() ? "" : (input + ": ").c_str());
        return 1;
    } catch (const std::exception& e) {
        tesswave::remove_run_outputs();
        std::fprintf(stderr, "tesswave: internal error: %s\n", one_line(e.what()).c_str());
        return 3;
    }
    return 0;
}
