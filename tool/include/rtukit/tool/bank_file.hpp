// rtukit device profiles, host side: the generic slave's memory (a
// driver MemoryBank: four tables and identification objects, no rows) filled
// from a JSON file, as `rtukit slave --init` and tests start one:
//
//   {"holding": {"0x21": [1, 2, 3], "0": 5}, "input": {...}, "coils": {...}, "discrete": {...},
//    "identification": {"vendor": "ACME", "product_code": "M-3", "revision": "2.1", "0x80": "..."}}
//
// A table maps a first address (decimal or 0x hex) to a value or a list of
// values from there on; identification maps a standard object's key
// (device_object_key, protocol_text.hpp) or an id to its text.
#pragma once

#include <string>
#include <string_view>

#include "rtukit/base/status.hpp"
#include "rtukit/driver/memory_bank.hpp"

namespace rtukit::tool {

/// Fills `bank` from the file at `path` (at most 16 MiB). Errors, the reason
/// naming the file: io_error or malformed as io::read_regular_file gives
/// them ("cannot read PATH: ..."); invalid_argument for what the file says
/// (not JSON, an unknown table, an address past the bank's tables, a value
/// out of a table's range, an identification text that is empty or over 244
/// bytes). On error the bank may hold part of the file.
Status load_bank_file(const std::string& path, MemoryBank& bank);

/// The same from the file's text; `source` names it in reasons.
Status load_bank_text(std::string_view source, std::string_view text, MemoryBank& bank);

}  // namespace rtukit::tool
