// The scripted mouse (the test input of the palpation window), the mouse-to-device mapping and
// the ST tone: synthesis against the analytic sine, playback through ALSA's "null" PCM (no sound
// card needed), and a missing card that leaves the cue unavailable without failing.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <thread>

#include "common/input_error.hpp"
#include "engine/render/mouse_control.hpp"
#include "engine/render/mouse_script.hpp"
#include "engine/render/tone_cue.hpp"

using namespace palplab;
using namespace palplab::render;

TEST(MouseScript, StatesHoldWheelIsDeliveredOnceCloseLatches) {
  MouseScript s = MouseScript::parse(R"({"palplab_mouse_script": 1, "instructions_seconds": 0.1,
    "events": [{"t": 0, "x": 10, "y": 20, "left": true}, {"t": 0.5, "wheel": 3},
               {"t": 0.5, "wheel": 1}, {"t": 1.0, "left": false, "right": true, "x": 11, "y": 22},
               {"t": 2.0, "close": true}]})",
                                     "s.json");
  EXPECT_DOUBLE_EQ(s.instructions_seconds(), 0.1);
  bool close = false;
  WindowInput in = s.input_at(0.0, close);
  EXPECT_TRUE(in.left);
  EXPECT_EQ(in.mouse_x, 10);
  EXPECT_EQ(in.scroll, 0);
  in = s.input_at(0.6, close);
  EXPECT_EQ(in.scroll, 4);  // both notches of t = 0.5, once
  EXPECT_TRUE(in.left);
  in = s.input_at(0.7, close);
  EXPECT_EQ(in.scroll, 0);
  in = s.input_at(1.5, close);
  EXPECT_FALSE(in.left);
  EXPECT_TRUE(in.right);
  EXPECT_EQ(in.mouse_y, 22);
  EXPECT_FALSE(close);
  s.input_at(2.0, close);
  EXPECT_TRUE(close);
  s.restart();
  in = s.input_at(0.0, close);
  EXPECT_FALSE(close);
  EXPECT_TRUE(in.left);
}

TEST(MouseScript, BadScriptsAreLocatedInputErrors) {
  auto msg = [](const std::string& text) {
    try {
      MouseScript::parse(text, "m.json");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("<accepted>");
  };
  EXPECT_NE(
      msg(R"({"palplab_mouse_script": 1, "events": [{"t": 1}, {"t": 0.5}]})").find("m.json:1:"),
      std::string::npos);
  EXPECT_NE(msg(R"({"palplab_mouse_script": 1, "events": [{"t": 1}, {"t": 0.5}]})")
                .find("$.events[1].t: expected times that do not decrease"),
            std::string::npos);
  EXPECT_NE(msg(R"({"palplab_mouse_script": 1, "events": [{"t": 0, "x": 3}]})")
                .find("both \"x\" and \"y\""),
            std::string::npos);
  EXPECT_NE(msg(R"({"palplab_mouse_script": 1, "events": [{"t": 0, "lft": true}]})")
                .find("$.events[0].lft"),
            std::string::npos);
  EXPECT_NE(msg(R"({"palplab_mouse_script": 2, "events": []})").find("palplab_mouse_script"),
            std::string::npos);
  EXPECT_NE(msg(R"({"events": []})").find("palplab_mouse_script"), std::string::npos);
  EXPECT_NE(msg(R"({"palplab_mouse_script": 1, "events": [{"t": -1}]})").find("$.events[0].t"),
            std::string::npos);
}

TEST(ToneCue, BlockIsTheSineWithContinuousPhaseAndLinearFade) {
  const int rate = 44100;
  const double f = 880.0;
  double phase = 0.0;
  // Two blocks back to back equal one long sine: the phase carries over.
  auto a = tone_block(f, rate, 441, 0.5, 0.5, phase);
  auto b = tone_block(f, rate, 441, 0.5, 0.5, phase);
  for (int i = 0; i < 882; ++i) {
    const double expected = 32767.0 * 0.5 * std::sin(2.0 * M_PI * f * i / rate);
    const double got = i < 441 ? a[i] : b[i - 441];
    ASSERT_NEAR(got, expected, 1.0) << i;  // rounding to int16 only
  }
  // 20 ms at 880 Hz: 17.6 periods -> 35 sign changes.
  int changes = 0;
  for (int i = 1; i < 882; ++i) {
    const int s0 = i - 1 < 441 ? a[i - 1] : b[i - 1 - 441];
    const int s1 = i < 441 ? a[i] : b[i - 441];
    changes += (s0 < 0) != (s1 < 0);
  }
  EXPECT_NEAR(changes, 2 * f * 0.02, 1.0);
  // A fade from 0 to 1: the envelope grows linearly, never above it.
  phase = M_PI / 2;  // start at a crest
  auto c = tone_block(f, rate, 220, 0.0, 1.0, phase);
  for (int i = 0; i < 220; ++i) EXPECT_LE(std::abs(c[i]), 32767.0 * (i + 1) / 220 + 1.0) << i;
}

TEST(ToneCue, PlaysThroughAlsaNullDeviceAtRealTimePace) {
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  ToneCue tone("null");
  ASSERT_TRUE(tone.available()) << tone.error();
  // Bounded waits, not fixed sleeps: a loaded machine may starve the audio thread for a while.
  auto within_10s = [](const auto& done) {
    const auto end = Clock::now() + std::chrono::seconds(10);
    while (!done() && Clock::now() < end) std::this_thread::sleep_for(std::chrono::milliseconds(5));
    return done();
  };
  constexpr long kBlock = ToneCue::kRate / 200;  // the thread's 5 ms blocks
  tone.set_on(true);
  ASSERT_TRUE(within_10s([&] { return tone.tone_frames() > ToneCue::kRate * 0.15; }));
  tone.set_on(false);
  const long on_frames = tone.tone_frames();
  const long off_from = tone.frames_written();
  ASSERT_TRUE(within_10s([&] { return tone.frames_written() > off_from + ToneCue::kRate / 20; }));
  const long written = tone.frames_written();
  const double elapsed = std::chrono::duration<double>(Clock::now() - t0).count();
  // Paced by the clock (the null device takes samples at any speed): never more than the time
  // since the thread started plus the 40 ms lead and the block in hand, not millions.
  EXPECT_LE(written, static_cast<long>((elapsed + 0.040) * ToneCue::kRate) + kBlock);
  // The tone stopped: at most the block in hand and one fade block after set_on(false).
  EXPECT_LE(tone.tone_frames() - on_frames, 2 * kBlock);
}

TEST(ToneCue, NoSoundCardMeansNoToneAndNoFailure) {
  ToneCue tone("hw:97,0");  // no such card here or anywhere sane
  EXPECT_FALSE(tone.available());
  EXPECT_NE(tone.error().find("hw:97,0"), std::string::npos);
  tone.set_on(true);  // harmless
  tone.set_on(false);
  EXPECT_EQ(tone.frames_written(), 0);
}
