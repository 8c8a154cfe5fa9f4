"""Rigid bodies and drives: planar bodies (`planar`), spatial bodies (`spatial`), the affine rows that tie members to
bodies (`rows`), prescribed motions and motors (`drives`)."""
