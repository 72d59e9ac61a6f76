#include "fluid_sim/ros/param_yaml.h"

#include <cstdio>
#include <sstream>
#include <stdexcept>

namespace fluid_sim
{
namespace ros_bridge
{
namespace
{
std::string quoted(const std::string& s)
{
  // A double-quoted YAML scalar: escape backslashes, quotes and control characters.
  std::string out = "\"";
  for (const char c : s)
  {
    switch (c)
    {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\t':
        out += "\\t";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20)
        {
          char buf[8];
          std::snprintf(buf, sizeof buf, "\\x%02x", static_cast<unsigned>(static_cast<unsigned char>(c)));
          out += buf;
        }
        else
        {
          out += c;
        }
    }
  }
  return out + "\"";
}

void write(std::ostringstream& os, const XmlRpc::XmlRpcValue& v)
{
  // XmlRpcValue's accessors are non-const; the value is not modified.
  auto& value = const_cast<XmlRpc::XmlRpcValue&>(v);
  switch (value.getType())
  {
    case XmlRpc::XmlRpcValue::TypeBoolean:
      os << (static_cast<bool>(value) ? "true" : "false");
      break;
    case XmlRpc::XmlRpcValue::TypeInt:
      os << static_cast<int>(value);
      break;
    case XmlRpc::XmlRpcValue::TypeDouble:
    {
      char buf[40];
      std::snprintf(buf, sizeof buf, "%.17g", static_cast<double>(value));
      std::string text = buf;
      // YAML reads "1" as an integer; the scene loader accepts integers for doubles, but keep
      // the type visible anyway.
      if (text.find_first_of(".eEni") == std::string::npos) text += ".0";
      os << text;
      break;
    }
    case XmlRpc::XmlRpcValue::TypeString:
      os << quoted(static_cast<std::string>(value));
      break;
    case XmlRpc::XmlRpcValue::TypeArray:
      os << '[';
      for (int i = 0; i < value.size(); ++i)
      {
        if (i > 0) os << ", ";
        write(os, value[i]);
      }
      os << ']';
      break;
    case XmlRpc::XmlRpcValue::TypeStruct:
    {
      os << '{';
      bool first = true;
      for (auto it = value.begin(); it != value.end(); ++it)
      {
        if (!first) os << ", ";
        first = false;
        os << quoted(it->first) << ": ";
        write(os, it->second);
      }
      os << '}';
      break;
    }
    case XmlRpc::XmlRpcValue::TypeInvalid:
      os << "null";
      break;
    default:
      throw std::invalid_argument("parameter of a type no scene key takes (base64 or date-time)");
  }
}
}  // namespace

std::string toYaml(const XmlRpc::XmlRpcValue& value)
{
  std::ostringstream os;
  write(os, value);
  return os.str();
}

std::string sceneYaml(const XmlRpc::XmlRpcValue& params, const std::set<std::string>& skip)
{
  std::ostringstream os;
  auto& value = const_cast<XmlRpc::XmlRpcValue&>(params);
  if (value.getType() != XmlRpc::XmlRpcValue::TypeStruct) return "{}\n";
  bool any = false;
  for (auto it = value.begin(); it != value.end(); ++it)
  {
    if (skip.count(it->first)) continue;
    std::ostringstream line;
    try
    {
      write(line, it->second);
    }
    catch (const std::invalid_argument& e)
    {
      throw std::invalid_argument(it->first + ": " + e.what());
    }
    os << quoted(it->first) << ": " << line.str() << '\n';
    any = true;
  }
  return any ? os.str() : "{}\n";
}

}  // namespace ros_bridge
}  // namespace fluid_sim
