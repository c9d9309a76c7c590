// The registry entry's shared parts: the generated sections of a device's doc.
#include "rtukit/devices/profile/device.hpp"

#include <fmt/core.h>

#include "rtukit/devices/profile/text.hpp"

namespace rtukit::profile {

std::vector<DocSection> doc_sections(const DeviceEntry& entry) {
  std::vector<DocSection> out;
  const Profile* p = entry.profile;
  out.push_back({"registers", entry.markdown ? entry.markdown : [p] { return registers_markdown(*p); }});
  // The device's own verbs, from the same table the CLI builds them from.
  if (!entry.verbs.empty())
    out.push_back({"commands", [&entry] { return verbs_markdown(entry.profile->name, entry.verbs); }});
  out.insert(out.end(), entry.doc_sections.begin(), entry.doc_sections.end());
  return out;
}

Outcome<std::string> regenerate_doc(const DeviceEntry& entry, std::string_view text) {
  std::string out(text);
  for (const DocSection& section : doc_sections(entry)) {
    const std::string tag = fmt::format("rtukit {} {}", entry.profile->name, section.name);
    const std::string begin = fmt::format("<!-- BEGIN GENERATED: {} -->\n", tag);
    const std::string end = fmt::format("<!-- END GENERATED: {} -->", tag);
    const size_t a = out.find(begin);
    const size_t b = a == std::string::npos ? a : out.find(end, a);
    if (b == std::string::npos)
      return Status(Errc::invalid_argument,
                    fmt::format("no generated section {}: the doc needs the lines {} and {}", tag,
                                begin.substr(0, begin.size() - 1), end));
    std::string body = section.markdown();
    if (!body.empty() && body.back() != '\n') body += '\n';
    out.replace(a + begin.size(), b - a - begin.size(), body);
  }
  return out;
}

}  // namespace rtukit::profile
