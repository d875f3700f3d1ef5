// vadop_predict: reads a scene (JSON, see scene_io.h), runs the broad and narrow phases over
// [0, horizon] and prints, one JSON object a line, every pair that comes into contact:
//   {"a":"<id>","b":"<id>","time":t,"point":[x,y,z],"normal":[x,y,z]}
// a is the body listed first in the input, the normal points from a to b; lines are sorted by
// time, then by the input order of a, then of b. A pair touching at t = 0 has time 0.
// Exit status: 0 done (also when nothing touches), 2 bad input or bad options (a one-line
// message on stderr, nothing on stdout), 1 anything else (I/O error on output, internal error).
#include "vadop/axis_pool.h"
#include "vadop/error.h"
#include "vadop/vadop.h"
#include "vadop/scene_io.h"
#include "vadop/world.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <string>

namespace {

const char* const kUsage =
    "usage: vadop_predict [scene.json | -] [--broadphase vadop|vadop_sap|sap|brute] [--axes M] [--phi DEG]\n"
    "\n"
    "Predicts every contact between the bodies of a JSON scene within [0, horizon] and prints one\n"
    "JSON object per line, sorted by time then input order:\n"
    "  {\"a\":\"<id>\",\"b\":\"<id>\",\"time\":t,\"point\":[x,y,z],\"normal\":[x,y,z]}\n"
    "(a = the body listed first, normal from a to b; a pair touching at t = 0 has time 0).\n"
    "\n"
    "  scene.json         the scene; '-' or none: standard input\n"
    "  --broadphase NAME  vadop (default: VADOP volumes on a grid), vadop_sap (VADOP with sweep\n"
    "                     and prune per axis), sap (sweep and prune of AABBs) or brute (all pairs);\n"
    "                     the output does not depend on it\n"
    "  --axes M           VADOP axis pool size, an integer in [3, 4096] (default 32)\n"
    "  --phi DEG          VADOP zone half-width in degrees, in [0, 90], at least the pool's\n"
    "                     covering radius; 0 selects that radius (default 25)\n"
    "  --help             this text\n"
    "\n"
    "Exit status: 0 success, 2 bad input or options (message on stderr, nothing on stdout),\n"
    "1 other errors.\n";

[[noreturn]] void die(int status, const std::string& message) {
  std::fprintf(stderr, "vadop_predict: %s\n", message.c_str());
  std::exit(status);
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
    badOption("--axes must be an integer in [3, 4096], got '" + v + "'");
  }
  return static_cast<int>(m);
}

double parsePhi(const std::string& v) {
  char* end = nullptr;
  const double phi = std::strtod(v.c_str(), &end);
  if (v.empty() || *end != '\0' || !std::isfinite(phi) || phi < 0.0 || phi > 90.0) {
    badOption("--phi must be a number of degrees in [0, 90] (0 = the pool's covering radius), got '" + v + "'");
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
      if (arg != "--broadphase" && arg != "--axes" && arg != "--phi") badOption("unknown option " + arg);
      if (!has_value) {
        if (i + 1 >= argc) badOption("missing value after " + arg);
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
      } else {
        o.config.vadop.phi_deg = parsePhi(value);
      }
      continue;
    }
    if (o.input_given) badOption("more than one scene file given ('" + o.input + "' and '" + arg + "')");
    o.input = arg;
    o.input_given = true;
  }
  return o;
}

std::string readStdin() {
  std::string text;
  char buf[65536];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, stdin)) > 0) text.append(buf, n);
  if (std::ferror(stdin)) die(2, std::string("cannot read standard input: ") + std::strerror(errno));
  return text;
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
    const std::string source = o.input == "-" ? "<stdin>" : o.input;
    std::string lines;
    try {
      const vadop::Scene scene = o.input == "-" ? vadop::parseScene(readStdin()) : vadop::readSceneFile(o.input);
      vadop::addToWorld(scene, world);
      // Everything is computed before anything is printed: on an error stdout stays empty.
      lines = vadop::impactsToJsonLines(world.predict(0.0, scene.horizon));
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
