// Keeps the library non-empty until the first sources land; removed with them.
namespace quatcurve {
int placeholder_symbol() { return 0; }
}
