// sombra — shadow technique "none" (cl/techniques/none.h): no device data, no arguments.
#include "techniques/technique.h"

namespace sombra::techniques {
namespace {

class NoShadows final : public ShadowModule {
public:
    void add_defines(const Scene&, const RenderOptions&, std::vector<std::string>&) const override {}
    bool has_shadow_term() const override { return false; }
};

}  // namespace

std::unique_ptr<ShadowModule> make_no_shadows(ShadowTechnique) { return std::make_unique<NoShadows>(); }

}  // namespace sombra::techniques
