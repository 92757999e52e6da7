//! surfacer — turns codimfx particle caches into renderable geometry.
