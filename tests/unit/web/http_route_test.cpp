// HttpRoute: a request target is judged as the client sent
// it, before decoding; one with a control byte or a space is a 400 whatever
// its method and path.
#include "web/http_route.hpp"

#include <gtest/gtest.h>

#include <string>

using cobridge::web::is_clean_target;
using cobridge::web::Resource;
using cobridge::web::route_request;

namespace {

TEST(HttpRoute, ATargetWithAControlByteOrSpaceIsNotClean) {
  for (int c = 0; c < 0x20; ++c) {
    EXPECT_FALSE(is_clean_target("/metrics" + std::string(1, static_cast<char>(c)) + "x")) << c;
  }
  EXPECT_FALSE(is_clean_target(std::string("/metrics\0x", 10)));
  EXPECT_FALSE(is_clean_target("/metrics\x7f"));
  EXPECT_FALSE(is_clean_target("/metrics x"));
  EXPECT_FALSE(is_clean_target("/metrics?a=b c"));
}

// Percent-encoded, they would be control bytes once libmicrohttpd decodes them.
TEST(HttpRoute, APercentEscapeOfAControlByteIsNotClean) {
  for (const char* t : {"/metrics%00x", "/metrics%0a", "/metrics%0D", "/metrics%1f", "/metrics%1F", "/metrics%7F",
                        "/metrics?x=%00", "%00"})
    EXPECT_FALSE(is_clean_target(t)) << t;
}

TEST(HttpRoute, OrdinaryTargetsAreClean) {
  for (const char* t : {"/", "/metrics", "/api/v1/status", "/metrics?x=%41&y=%20", "/%7e", "/%80", "/%", "/%0",
                        "/%zz", "/metrics%", "/caf\xc3\xa9"})
    EXPECT_TRUE(is_clean_target(t)) << t;
}

TEST(HttpRoute, AnUncleanTargetIs400WhateverTheMethodAndPath) {
  for (const char* method : {"GET", "HEAD", "POST"}) {
    const auto r = route_request(method, "/metrics", false);
    EXPECT_EQ(r.status, 400U) << method;
    EXPECT_EQ(r.resource, Resource::none);
    EXPECT_NE(std::string(r.reason).find("control byte"), std::string::npos) << r.reason;
  }
  EXPECT_EQ(route_request("GET", "/metrics", true).status, 200U);
}

// docs/web.md "Flight recorder captures": /api/v1/captures/NAME serves a
// capture by its file name, and only a plain name the recorder could have
// written (no path, no "..", ending in .log).
TEST(HttpRoute, CapturesByPlainNameOnly) {
  const auto ok = route_request("GET", "/api/v1/captures/line1-20261128T021500Z-boot-up.log", true);
  EXPECT_EQ(ok.status, 200U);
  EXPECT_EQ(ok.resource, Resource::capture);
  EXPECT_EQ(ok.capture, "line1-20261128T021500Z-boot-up.log");
  for (const char* bad : {"/api/v1/captures/", "/api/v1/captures/../state/assignments.state",
                          "/api/v1/captures/a/b.log", "/api/v1/captures/..log", "/api/v1/captures/x..y.log",
                          "/api/v1/captures/.hidden.log", "/api/v1/captures/x.json", "/api/v1/captures/x y.log"}) {
    const auto r = route_request("GET", bad, true);
    EXPECT_EQ(r.status, 404U) << bad;
    EXPECT_EQ(r.resource, Resource::none) << bad;
  }
}

}  // namespace
