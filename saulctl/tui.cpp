// The only file that includes <curses.h> (built outside the unity batches: saulctl/CMakeLists.txt).
#include "tui.hpp"

#include <curses.h>
#include <unistd.h>

#include <cstdio>
#include <utility>

namespace saulctl::tui {

struct Screen::Term {
  SCREEN* screen = nullptr;
  bool colour = false;
};

std::unique_ptr<Screen> Screen::open() {
  if (!::isatty(STDOUT_FILENO) || !::isatty(STDIN_FILENO)) return nullptr;
  // newterm, not initscr: an unknown TERM gives nullptr here instead of ending the program.
  SCREEN* s = ::newterm(nullptr, stdout, stdin);
  if (s == nullptr) return nullptr;
  std::unique_ptr<Screen> screen(new Screen());
  screen->term_ = new Term{s, false};
  ::cbreak();  // keys at once; Ctrl-C still raises SIGINT (saulctl's handler ends the view cleanly)
  ::noecho();
  ::nodelay(stdscr, TRUE);
  ::keypad(stdscr, TRUE);
  ::curs_set(0);
  if (::has_colors()) {
    ::start_color();
    ::use_default_colors();
    ::init_pair(1, COLOR_GREEN, -1);
    ::init_pair(2, COLOR_YELLOW, -1);
    ::init_pair(3, COLOR_RED, -1);
    ::init_pair(4, COLOR_CYAN, -1);
    screen->term_->colour = true;
  }
  return screen;
}

Screen::~Screen() {
  if (term_ == nullptr) return;
  ::endwin();
  ::delscreen(term_->screen);
  delete term_;
}

int Screen::width() const { return COLS; }
int Screen::height() const { return LINES; }

void Screen::begin() { erase(); }

int Screen::put(int row, int col, std::string_view text, Style style) {
  if (row < 0 || row >= LINES || col >= COLS) return col;
  const int room = COLS - col;
  const int n = static_cast<int>(text.size()) < room ? static_cast<int>(text.size()) : room;
  // Each Style's attributes and colour pair (open()), in the enum's order: normal, title (cyan), good (green),
  // warn (yellow), bad (red), dim, inverse.
  static const std::pair<attr_t, short> kLooks[] = {{A_NORMAL, 0}, {A_BOLD, 4}, {A_NORMAL, 1}, {A_BOLD, 2},
                                                    {A_BOLD, 3},   {A_DIM, 0},  {A_REVERSE, 0}};
  const auto [a, pair] = kLooks[static_cast<int>(style)];
  attr_set(a, term_->colour ? pair : 0, nullptr);
  // The last cell of the last line cannot be written without scrolling: leave it out.
  const int len = row == LINES - 1 && col + n >= COLS ? n - 1 : n;
  if (len > 0) mvaddnstr(row, col, text.data(), len);
  attr_set(A_NORMAL, 0, nullptr);
  return col + n;
}

void Screen::show() { refresh(); }

int Screen::key() {
  const int k = getch();
  return k == ERR ? -1 : k;
}

}  // namespace saulctl::tui
