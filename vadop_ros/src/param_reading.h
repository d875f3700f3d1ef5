// Reading ~ parameters (XmlRpc values) with errors that name the parameter: shared by the
// parameter parser (params.cpp) and the input kinds that read their own keys of a ~bodies entry
// (src/sources). Internal to vadop_ros (not installed).
#pragma once

#include "vadop_ros/params.h"

#include <xmlrpcpp/XmlRpcValue.h>

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

}  // namespace param_reading
}  // namespace vadop_ros
