//! The impulses: Coulomb's friction cone and non-penetration, solved contact by contact.
