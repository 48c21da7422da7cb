// saulctl's full-screen views (monitor, sniff --top) on ncurses, behind a small interface so that no command file
// includes <curses.h> (its macros - timeout, clear, OK, ERR - would leak into the unity batches). A view draws a
// whole screen each time; put() clips at the right edge, so nothing ever wraps.
#pragma once

#include <memory>
#include <string>
#include <string_view>

namespace saulctl::tui {

enum class Style : unsigned char {
  normal,
  title,    ///< headings, bold
  good,     ///< green: BALANCE, a stream that is fresh
  warn,     ///< yellow: stale, warning states, changed bytes
  bad,      ///< red: ESTOP, TILT_CUTOFF, FAULT, fault bits, link lost, bus-off
  dim,      ///< labels, units
  inverse,  ///< the key line, a changed byte
};

class Screen {
 public:
  /// A full-screen view, or nullptr when stdout or stdin is no terminal or the terminal is unknown to ncurses.
  static std::unique_ptr<Screen> open();
  ~Screen();
  Screen(const Screen&) = delete;
  Screen& operator=(const Screen&) = delete;

  [[nodiscard]] int width() const;
  [[nodiscard]] int height() const;
  /// Starts a new frame (blank screen, not yet shown).
  void begin();
  /// Writes text at row, col in a style; whatever does not fit before the right edge is cut, never wrapped.
  /// Returns the column after the text.
  int put(int row, int col, std::string_view text, Style style = Style::normal);
  /// Shows the frame.
  void show();
  /// The next key pressed, or -1 (never waits). Letters come as themselves; ' ' for space.
  int key();

 private:
  Screen() = default;
  struct Term;
  Term* term_ = nullptr;
};

}  // namespace saulctl::tui
