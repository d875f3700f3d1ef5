// Test helper: YAML text -> XmlRpcValue, the way rosparam loads it (bool, int, double, string,
// list, dictionary), so that the tests can write parameters as the config files do.
#pragma once

#include <xmlrpcpp/XmlRpcValue.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <sstream>
#include <string>

namespace vadop_test {

inline XmlRpc::XmlRpcValue toXmlRpc(const YAML::Node& n) {
  XmlRpc::XmlRpcValue v;
  switch (n.Type()) {
    case YAML::NodeType::Map:
      v.begin();  // makes it a struct (begin() on an invalid value converts)
      for (const auto& kv : n) v[kv.first.as<std::string>()] = toXmlRpc(kv.second);
      return v;
    case YAML::NodeType::Sequence:
      v.setSize(static_cast<int>(n.size()));
      for (size_t i = 0; i < n.size(); ++i) v[static_cast<int>(i)] = toXmlRpc(n[i]);
      return v;
    case YAML::NodeType::Scalar: {
      const std::string s = n.Scalar();
      if (n.Tag() == "!") return XmlRpc::XmlRpcValue(s);  // quoted: a string
      if (s == "true" || s == "True") return XmlRpc::XmlRpcValue(true);
      if (s == "false" || s == "False") return XmlRpc::XmlRpcValue(false);
      try {
        size_t pos = 0;
        const long i = std::stol(s, &pos);
        if (pos == s.size()) return XmlRpc::XmlRpcValue(static_cast<int>(i));
      } catch (...) {
      }
      try {
        size_t pos = 0;
        const double d = std::stod(s, &pos);
        if (pos == s.size()) return XmlRpc::XmlRpcValue(d);
      } catch (...) {
      }
      if (s == ".nan" || s == ".NaN") return XmlRpc::XmlRpcValue(std::nan(""));
      return XmlRpc::XmlRpcValue(s);
    }
    default:
      return v;
  }
}

inline XmlRpc::XmlRpcValue yaml(const std::string& text) { return toXmlRpc(YAML::Load(text)); }

inline std::string readFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace vadop_test
