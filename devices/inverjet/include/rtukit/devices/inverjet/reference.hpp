// The Inverjet's register reference as docs/inverjet.md embeds it
// (`rtukit inverjet registers`; scripts/gen-docs.sh regenerates the docs).
#pragma once

#include <string>

namespace rtukit::inverjet {

/// The register reference as a Markdown table.
std::string registers_markdown();

}  // namespace rtukit::inverjet
