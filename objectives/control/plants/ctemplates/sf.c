
static PFX_real clip(PFX_real v, PFX_real lo, PFX_real hi)
{
    return v < lo ? lo : (v > hi ? hi : v);
}
