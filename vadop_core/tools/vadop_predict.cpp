// vadop_predict: reads a scene (JSON, see scene_io.h), runs the broad and narrow phases over
// [0, horizon] and prints, one JSON object a line, every pair that comes into contact:
//   {"a":"<id>","b":"<id>","time":t,"point":[x,y,z],"normal":[x,y,z]}
// and every pair the narrow phase could not decide within its budget (clear until t, unknown
// after; not a contact):
//   {"a":"<id>","b":"<id>","undecided_after":t}
// a is the body listed first in the input, the normal points from a to b; lines are sorted by
// time, then by the input order of a, then of b. A pair touching at t = 0 has time 0.
// Exit status: 0 done (also when nothing touches), 2 bad input or bad options (one line of at
// most kMaxLineBytes on stderr, nothing on stdout), 1 anything else (I/O error on output,
// internal error). Input is read up to vadop::kMaxSceneBytes (scene_io.h).
#include "vadop/axis_pool.h"
#include "vadop/error.h"
#include "vadop/vadop.h"
#include "vadop/scene_io.h"
#include "vadop/world.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <iostream>
#include <string>
#include <vector>

namespace {

const char* const kUsage =
    "usage: vadop_predict [scene.json | -] [--broadphase vadop|vadop_sap|sap|grid|brute] [--axes M] [--phi DEG]\n"
    "                     [--max-iterations N]\n"
    "\n"
    "Predicts every contact between the bodies of a JSON scene within [0, horizon] and prints one\n"
    "JSON object per line, sorted by time then input order:\n"
    "  {\"a\":\"<id>\",\"b\":\"<id>\",\"time\":t,\"point\":[x,y,z],\"normal\":[x,y,z]}\n"
    "(a = the body listed first, normal from a to b; a pair touching at t = 0 has time 0), and\n"
    "every pair the narrow phase could not decide (clear until t, unknown after; not a contact):\n"
    "  {\"a\":\"<id>\",\"b\":\"<id>\",\"undecided_after\":t}\n"
    "\n"
    "  scene.json         the scene (at most 64 MiB); '-' or none: standard input\n"
    "  --broadphase NAME  vadop (default: VADOP volumes on a grid), vadop_sap (VADOP with sweep\n"
    "                     and prune per axis), sap (sweep and prune of AABBs), grid (uniform grid\n"
    "                     of swept AABBs) or brute (all pairs);\n"
    "                     the output does not depend on it\n"
    "  --axes M           VADOP axis pool size, an integer in [3, 4096] (default 32)\n"
    "  --phi DEG          VADOP zone half-width in degrees, in [0, 90], at least the pool's\n"
    "                     covering radius; 0 selects that radius (default 25)\n"
    "  --max-iterations N narrow-phase budget per pair, an integer in [1, 100000000] (default\n"
    "                     10000); a pair not decided within it prints as undecided\n"
    "  --help             this text\n"
    "\n"
    "Exit status: 0 success, 2 bad input or options (message on stderr, nothing on stdout),\n"
    "1 other errors.\n";

// Every message is one line of at most this many bytes (newline included): the library's
// messages are bounded by vadop::kMaxMessageBytes, "vadop_predict: <file>: " adds at most 100.
constexpr size_t kMaxLineBytes = vadop::kMaxMessageBytes + 100;

[[noreturn]] void die(int status, const std::string& message) {
  const std::string line = vadop::boundedMessage("vadop_predict: " + message, kMaxLineBytes - 1) + "\n";
  std::fputs(line.c_str(), stderr);
  std::exit(status);
}

// A file name or argument as messages show it: as is when short and printable, else quoted and
// shortened (vadop::messageQuote).
std::string shown(const std::string& s) {
  const bool plain = s.size() <= 64 && std::all_of(s.begin(), s.end(), [](char c) { return c >= 0x20 && c < 0x7f; });
  return plain ? s : vadop::messageQuote(s);
}

[[noreturn]] void badOption(const std::string& message) {
  die(2, message + " (see --help)");
}

struct Options {
  std::string input = "-";
  bool input_given = false;
  vadop::WorldConfig config;
};

int parseAxes(const std::string& v) {
  errno = 0;
  char* end = nullptr;
  const long m = std::strtol(v.c_str(), &end, 10);
  if (v.empty() || *end != '\0' || errno != 0 || m < 3 || m > 4096) {
    badOption("--axes must be an integer in [3, 4096], got '" + shown(v) + "'");
  }
  return static_cast<int>(m);
}

int parseMaxIterations(const std::string& v) {
  errno = 0;
  char* end = nullptr;
  const long n = std::strtol(v.c_str(), &end, 10);
  if (v.empty() || *end != '\0' || errno != 0 || n < 1 || n > 100000000) {
    badOption("--max-iterations must be an integer in [1, 100000000], got '" + shown(v) + "'");
  }
  return static_cast<int>(n);
}

double parsePhi(const std::string& v) {
  char* end = nullptr;
  const double phi = std::strtod(v.c_str(), &end);
  if (v.empty() || *end != '\0' || !std::isfinite(phi) || phi < 0.0 || phi > 90.0) {
    badOption("--phi must be a number of degrees in [0, 90] (0 = the pool's covering radius), got '" + shown(v) + "'");
  }
  return phi;
}

Options parse(int argc, char** argv) {
  Options o;
  bool options_done = false;
  for (int i = 1; i < argc; ++i) {
    std::string arg = argv[i];
    if (!options_done && arg == "--") {
      options_done = true;
      continue;
    }
    if (!options_done && arg.size() > 1 && arg[0] == '-') {
      if (arg == "--help" || arg == "-h") {
        std::fputs(kUsage, stdout);
        std::exit(std::fflush(stdout) == 0 ? 0 : 1);
      }
      std::string value;
      bool has_value = false;
      const size_t eq = arg.find('=');
      if (arg.rfind("--", 0) == 0 && eq != std::string::npos) {
        value = arg.substr(eq + 1);
        arg = arg.substr(0, eq);
        has_value = true;
      }
      if (arg != "--broadphase" && arg != "--axes" && arg != "--phi" && arg != "--max-iterations") {
        badOption("unknown option " + shown(arg));
      }
      if (!has_value) {
        if (i + 1 >= argc) badOption("missing value after " + shown(arg));
        value = argv[++i];
      }
      if (arg == "--broadphase") {
        try {
          o.config.broad_phase = vadop::parseBroadPhaseKind(value);
        } catch (const vadop::InvalidArgument& e) {
          badOption(std::string("--broadphase: ") + e.what());
        }
      } else if (arg == "--axes") {
        o.config.vadop.axes = parseAxes(value);
      } else if (arg == "--max-iterations") {
        o.config.toi.max_iterations = parseMaxIterations(value);
      } else {
        o.config.vadop.phi_deg = parsePhi(value);
      }
      continue;
    }
    if (o.input_given) badOption("more than one scene file given ('" + shown(o.input) + "' and '" + shown(arg) + "')");
    o.input = arg;
    o.input_given = true;
  }
  return o;
}

}  // namespace

int main(int argc, char** argv) {
  const Options o = parse(argc, argv);
  try {
    // The configuration first: a bad --axes/--phi combination is reported before any input is read.
    vadop::World world = [&] {
      try {
        // --axes/--phi are checked whatever the broad phase (World checks them for vadop only).
        if (o.config.broad_phase != vadop::BroadPhaseKind::kVadop) {
          vadop::validateVadopConfig(o.config.vadop, vadop::AxisPool(o.config.vadop.axes));
        }
        return vadop::World(o.config);
      } catch (const vadop::InvalidArgument& e) {
        badOption(std::string("bad VADOP configuration (--axes ") + std::to_string(o.config.vadop.axes) +
                  ", --phi " + std::to_string(o.config.vadop.phi_deg) + "): " + e.what());
      }
    }();
    const std::string source = o.input == "-" ? "<stdin>" : shown(o.input);
    std::string lines;
    try {
      // Both read at most vadop::kMaxSceneBytes + 1 bytes (a pipe or /dev/zero included).
      const vadop::Scene scene =
          o.input == "-" ? vadop::readScene(std::cin, "standard input") : vadop::readSceneFile(o.input);
      vadop::addToWorld(scene, world);
      // Everything is computed before anything is printed: on an error stdout stays empty.
      const std::vector<vadop::Contact> contacts = world.predict(0.0, scene.horizon);
      lines = vadop::predictionToJsonLines(contacts, world.lastUndecided());
    } catch (const vadop::InvalidArgument& e) {
      die(2, source + ": " + e.what());
    }
    if (std::fwrite(lines.data(), 1, lines.size(), stdout) != lines.size() || std::fflush(stdout) != 0) {
      die(1, std::string("cannot write the output: ") + std::strerror(errno));
    }
    return 0;
  } catch (const std::exception& e) {
    die(1, std::string("internal error: ") + e.what());
  }
}
