// Protocol facts and device-terms views that every front-end shares (issue
// 27: moved out of the CLI): the FC0C comm event bytes and the FC2B/0E
// object names (core).
#include <gtest/gtest.h>

#include <string>

#include "rtukit/core/pdu.hpp"

namespace rtukit {
namespace {

std::string event(uint8_t e) {
  char buffer[kCommEventTextSize];
  return std::string(comm_event_text(e, buffer));
}

TEST(ProtocolViews, CommEventBytesInWords) {
  EXPECT_EQ(event(comm_event::kRestart), "communications restart");
  EXPECT_EQ(event(comm_event::kEnteredListenOnly), "entered listen-only mode");
  EXPECT_EQ(event(0x80), "received");
  EXPECT_EQ(event(0xC0), "received broadcast");
  EXPECT_EQ(event(0x82), "received, communication error");
  EXPECT_EQ(event(0xF2), "received broadcast, communication error, character overrun, in listen-only mode");
  EXPECT_EQ(event(0x40), "sent");
  EXPECT_EQ(event(0x44), "sent, busy exception");
  // Every send bit at once: the longest text there is, and it fits.
  EXPECT_EQ(event(0x7F),
            "sent, read exception, server abort exception, busy exception, NAK exception, write timeout, "
            "in listen-only mode");
  EXPECT_EQ(event(0x05), "event 0x05");
  EXPECT_EQ(event(0x3A), "event 0x3A");
}

TEST(ProtocolViews, DeviceObjectNamesKeysAndConformity) {
  EXPECT_STREQ(device_object_name(0), "vendor");
  EXPECT_STREQ(device_object_name(1), "product code");
  EXPECT_STREQ(device_object_name(3), "vendor URL");
  EXPECT_STREQ(device_object_name(6), "application");
  EXPECT_EQ(device_object_name(7), nullptr);
  EXPECT_EQ(device_object_name(0x80), nullptr);
  EXPECT_STREQ(device_object_key(1), "product_code");
  EXPECT_STREQ(device_object_key(3), "vendor_url");
  EXPECT_EQ(device_object_key(7), nullptr);
  EXPECT_STREQ(conformity_level_name(0x01), "basic");
  EXPECT_STREQ(conformity_level_name(0x82), "regular");  // bit 7: individual access too
  EXPECT_STREQ(conformity_level_name(0x83), "extended");
  EXPECT_STREQ(conformity_level_name(0x04), "unknown");
}

}  // namespace
}  // namespace rtukit
