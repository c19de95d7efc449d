#pragma once
// The ST audio cue as a tone through the sound card (ALSA, libasound2 from Debian): a sine at
// `frequency` Hz that sounds while set_on(true), with 5 ms fades so switching it at haptic rate
// does not click. The samples are synthesised here (no sound file). A thread of its own feeds the
// card in 5 ms blocks, paced by the steady clock (a device that accepts samples faster than real
// time, ALSA's "null", does not make it spin). Without a sound card (or with ALSA unable to open
// the device) the cue is simply unavailable: available() is false, error() says why, nothing
// fails; the window's flash is the cue then.
#include <atomic>
#include <cstdint>
#include <string>
#include <thread>
#include <vector>

namespace palplab::render {

// `frames` mono samples of a sine at `frequency` (Hz, sample rate `rate`), amplitude moving
// linearly from `amp_from` to `amp_to` (full scale 1) over the block; `phase` (rad) continues
// from the previous block and is advanced.
std::vector<std::int16_t> tone_block(double frequency, int rate, int frames, double amp_from,
                                     double amp_to, double& phase);

class ToneCue {
 public:
  // `device`: an ALSA PCM name; "" = $PALPLAB_AUDIO_DEVICE or else "default".
  explicit ToneCue(std::string device = "", double frequency = 880.0, double volume = 0.3);
  ~ToneCue();
  ToneCue(const ToneCue&) = delete;
  ToneCue& operator=(const ToneCue&) = delete;

  void set_on(bool on) { on_.store(on, std::memory_order_relaxed); }
  bool available() const { return pcm_ != nullptr; }
  const std::string& error() const { return error_; }
  const std::string& device() const { return device_; }
  long frames_written() const { return written_.load(); }
  long tone_frames() const { return tone_.load(); }  // frames with the tone audible (> 0)
  static constexpr int kRate = 44100;

 private:
  void loop();
  std::string device_, error_;
  double frequency_, volume_;
  void* pcm_ = nullptr;  // snd_pcm_t*
  std::atomic<bool> on_{false}, stop_{false};
  std::atomic<long> written_{0}, tone_{0};
  std::thread thread_;
};

}  // namespace palplab::render
