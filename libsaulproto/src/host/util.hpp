// Private helpers shared by several host sources (not installed, not part of the API).
#pragma once

namespace saul::host::detail {

/// ASCII lower case, whatever the C locale says (capture formats are ASCII).
constexpr char ascii_lower(char c) noexcept { return c >= 'A' && c <= 'Z' ? static_cast<char>(c - 'A' + 'a') : c; }

/// One visitor out of several lambdas, for std::visit over message variants.
template <class... F>
struct Overload : F... {
  using F::operator()...;
};
template <class... F>
Overload(F...) -> Overload<F...>;

}  // namespace saul::host::detail
