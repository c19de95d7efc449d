#include "engine/render/tone_cue.hpp"

#include <alsa/asoundlib.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>

namespace palplab::render {

namespace {
// ALSA reports a missing card on stderr through its own handler ("ALSA lib ... cannot find card
// '0'") before returning the error we report ourselves: keep it quiet.
void quiet_alsa(const char*, int, const char*, int, const char*, ...) {}
}  // namespace

std::vector<std::int16_t> tone_block(double frequency, int rate, int frames, double amp_from,
                                     double amp_to, double& phase) {
  std::vector<std::int16_t> out(static_cast<std::size_t>(std::max(frames, 0)));
  const double dphi = 2.0 * M_PI * frequency / rate;
  for (int i = 0; i < frames; ++i) {
    const double a = amp_from + (amp_to - amp_from) * (i + 1) / frames;
    out[i] = static_cast<std::int16_t>(std::lround(32767.0 * a * std::sin(phase)));
    phase += dphi;
  }
  phase = std::fmod(phase, 2.0 * M_PI);
  return out;
}

ToneCue::ToneCue(std::string device, double frequency, double volume)
    : device_(std::move(device)), frequency_(frequency), volume_(std::clamp(volume, 0.0, 1.0)) {
  if (device_.empty()) {
    const char* env = std::getenv("PALPLAB_AUDIO_DEVICE");
    device_ = env && *env ? env : "default";
  }
  snd_lib_error_set_handler(quiet_alsa);
  snd_pcm_t* pcm = nullptr;
  int rc = snd_pcm_open(&pcm, device_.c_str(), SND_PCM_STREAM_PLAYBACK, 0);
  if (rc >= 0)
    rc = snd_pcm_set_params(pcm, SND_PCM_FORMAT_S16_LE, SND_PCM_ACCESS_RW_INTERLEAVED, 1, kRate, 1,
                            30000 /* us latency */);
  if (rc < 0) {
    error_ = "ALSA device \"" + device_ + "\": " + snd_strerror(rc);
    if (pcm) snd_pcm_close(pcm);
    return;
  }
  pcm_ = pcm;
  thread_ = std::thread([this] { loop(); });
}

ToneCue::~ToneCue() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  if (pcm_) {
    snd_pcm_drop(static_cast<snd_pcm_t*>(pcm_));
    snd_pcm_close(static_cast<snd_pcm_t*>(pcm_));
    snd_config_update_free_global();  // ALSA's configuration cache (palplab opens no other PCM)
  }
}

void ToneCue::loop() {
  auto* pcm = static_cast<snd_pcm_t*>(pcm_);
  constexpr int kBlock = kRate / 200;  // 5 ms: the cue follows the force within ~5 ms + latency
  double phase = 0.0, amp = 0.0;
  const auto t0 = std::chrono::steady_clock::now();
  long frames = 0;
  while (!stop_.load()) {
    const double target = on_.load(std::memory_order_relaxed) ? volume_ : 0.0;
    // One block fades all the way (5 ms): no click when the cue switches.
    std::vector<std::int16_t> b = tone_block(frequency_, kRate, kBlock, amp, target, phase);
    if (amp > 0.0 || target > 0.0) tone_ += kBlock;
    amp = target;
    snd_pcm_sframes_t n = snd_pcm_writei(pcm, b.data(), kBlock);
    if (n < 0) n = snd_pcm_recover(pcm, static_cast<int>(n), 1);  // underrun: carry on
    if (n < 0) break;                                             // the device went away
    frames += kBlock;
    written_ = frames;
    // Never more than 40 ms ahead of the wall clock.
    const auto due = t0 + std::chrono::microseconds((frames * 1000000L) / kRate - 40000);
    std::this_thread::sleep_until(due);
  }
}

}  // namespace palplab::render
