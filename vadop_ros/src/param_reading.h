// Reading ~ parameters (XmlRpc values) with errors that name the parameter: shared by the
// parameter parser (params.cpp) and the input kinds that read their own keys of a ~bodies entry
// or their own top-level parameter (src/sources). Internal to vadop_ros (not installed).
#pragma once

#include "vadop_ros/params.h"

#include <xmlrpcpp/XmlRpcValue.h>

#include <set>
#include <string>

namespace vadop_ros {
namespace param_reading {

using XmlRpc::XmlRpcValue;

inline const char* typeName(const XmlRpcValue& v) {
  switch (v.getType()) {
    case XmlRpcValue::TypeBoolean: return "a boolean";
    case XmlRpcValue::TypeInt: return "an integer";
    case XmlRpcValue::TypeDouble: return "a number";
    case XmlRpcValue::TypeString: return "a string";
    case XmlRpcValue::TypeDateTime: return "a date";
    case XmlRpcValue::TypeBase64: return "binary data";
    case XmlRpcValue::TypeArray: return "a list";
    case XmlRpcValue::TypeStruct: return "a dictionary";
    default: return "nothing";
  }
}

// Throws ParamError "<path>: <what>".
[[noreturn]] inline void fail(const std::string& path, const std::string& what) {
  throw ParamError(path + ": " + what);
}

inline std::string toString(const XmlRpcValue& v, const std::string& path) {
  if (v.getType() != XmlRpcValue::TypeString) fail(path, std::string("must be a string, got ") + typeName(v));
  return static_cast<std::string>(const_cast<XmlRpcValue&>(v));
}

// The member `key` of the struct `s`, or null.
inline const XmlRpcValue* member(const XmlRpcValue& s, const std::string& key) {
  if (!s.hasMember(key)) return nullptr;
  return &s[key];
}

// A number as the errors print it.
std::string num(double v);
// A finite number (an integer is taken too).
double toDouble(const XmlRpcValue& v, const std::string& path);
void requireStruct(const XmlRpcValue& v, const std::string& path);
void requireArray(const XmlRpcValue& v, const std::string& path);
// Throws naming "<path>.<key>" for the first key of `s` not in `known`, with the nearest known
// key when the unknown one looks like its typo (nearestKey).
// The key of `known` a few edits from `key` (a typo of it), else "".
std::string nearestKey(const std::string& key, const std::set<std::string>& known);
void rejectUnknown(const XmlRpcValue& s, const std::set<std::string>& known, const std::string& path);
// A topic or parameter name the node's NodeHandle takes; `what`: "topic", "parameter name".
void checkRosName(const std::string& name, const std::string& path, const char* what);
// `def` when v is null, else a number in (lo, hi] (lo_open) or [lo, hi].
double ranged(const XmlRpcValue* v, double def, double lo, double hi, bool lo_open, const std::string& path);
// A ~bodies entry's topic `key` (into b.*topic) whose joints move a robot_description body's
// links, not with tf_prefix: joint_states_topic, joint_trajectory_topic. Nothing when absent.
void readJointTopic(const XmlRpcValue& entry, const std::string& path, const char* key,
                    std::string BodyParams::*topic, BodyParams& b);

}  // namespace param_reading
}  // namespace vadop_ros
