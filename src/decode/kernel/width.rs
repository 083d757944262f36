//! The vector instructions the kernel's batch runs with: found once, when a file is opened.

/// The vector instructions a batch uses: found once, when the file is opened (or chosen, for
/// tests: [`Width::forced`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Width {
    /// Whatever the build targets (SSE2 on x86-64): four lanes as two pairs.
    Base,
    /// Four binary64 lanes per instruction.
    Avx2,
    /// Eight binary64 lanes per instruction.
    Avx512,
}

impl Width {
    /// The widest this CPU offers.
    pub(super) fn detect() -> Self {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx512f")
                && std::arch::is_x86_feature_detected!("avx512dq")
                && std::arch::is_x86_feature_detected!("avx512vl")
            {
                return Width::Avx512;
            }
            if std::arch::is_x86_feature_detected!("avx2") {
                return Width::Avx2;
            }
        }
        Width::Base
    }

    /// Whether this CPU can run the width.
    pub(crate) fn available(self) -> bool {
        #[cfg(target_arch = "x86_64")]
        {
            match self {
                Width::Base => true,
                Width::Avx2 => std::arch::is_x86_feature_detected!("avx2"),
                Width::Avx512 => Width::detect() == Width::Avx512,
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            self == Width::Base
        }
    }
}
