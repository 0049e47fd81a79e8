#pragma once
// Optical blur of the scene simulator: point spread functions given by their
// analytic optical transfer functions (OTFs).
//
// All three kinds are radially symmetric and their OTFs are real, so the
// modulation transfer m(f) of the blur is known in closed form: the truth file
// of a simulated capture can quote psf_mtf() directly, and apply_psf() blurs
// with exactly that transfer (it multiplies the image's DFT by the OTF).
//
// Units: frequencies in cycles per sensor pixel, lengths in sensor pixels or
// micrometres as named. "Sensor pixel" is the camera's pixel; the renderer
// works on a supersampled image whose pixels are `pixel_scale` sensor pixels.

#include <string>

#include <opencv2/core/mat.hpp>

namespace tactres {

struct PsfOptions {
  enum Kind {
    gaussian,      // Gaussian spot, standard deviation sigma_px per axis
    defocus_disc,  // geometric defocus: uniform disc (pillbox) of radius radius_px
    diffraction,   // aberration-free circular pupil, incoherent light (Airy pattern)
  };
  Kind kind = gaussian;
  double sigma_px = 1.0;         // gaussian: sigma in sensor pixels, [0, 200]
  double radius_px = 2.0;        // defocus_disc: blur-circle radius in sensor pixels, [0, 200]
  double f_number = 2.8;         // diffraction: working f-number N, [0.5, 128]
  double wavelength_um = 0.55;   // diffraction: wavelength, [0.2, 20] um
  double pixel_pitch_um = 2.0;   // diffraction: sensor pixel pitch, [0.3, 100] um

  // Checks the fields the chosen kind uses; throws std::invalid_argument.
  void validate() const;
};

const char* to_string(PsfOptions::Kind kind);
// "gaussian", "defocus_disc" or "diffraction"; throws std::invalid_argument.
PsfOptions::Kind psf_kind_from_string(const std::string& name);

// Incoherent cutoff frequency of the diffraction-limited pupil, 1 / (lambda N),
// in cycles per sensor pixel. Above it the diffraction MTF is 0.
double diffraction_cutoff_cycles_per_px(const PsfOptions& options);

// The analytic transfer function (real; the MTF where it is >= 0) at the radial
// frequency |cycles_per_px| in cycles per sensor pixel. psf_mtf(o, 0) == 1.
//   gaussian:     exp(-2 pi^2 sigma^2 nu^2)
//   defocus_disc: 2 J1(2 pi R nu) / (2 pi R nu)   (negative between its zeros:
//                 contrast reversal; the MTF is the absolute value)
//   diffraction:  (2/pi) (acos x - x sqrt(1 - x^2)), x = nu / nu_c, 0 for x >= 1
// Throws std::invalid_argument for invalid options or a non-finite frequency.
double psf_mtf(const PsfOptions& options, double cycles_per_px);

// Blurs `image` (CV_32FC1, in place) with the PSF. `pixel_scale` is the size of
// one image pixel in sensor pixels (a renderer supersampling by s passes
// 1.0 / s), range (0, 16].
//
// The image is extended by reflection (BORDER_REFLECT) by several PSF widths,
// transformed with a real 2-D DFT, multiplied by the OTF sampled at every DFT
// frequency, transformed back and cropped. The blur is therefore the PSF
// band-limited to the image's sampling frequency: a sampled sinusoid of
// frequency f (below Nyquist) comes out scaled by exactly psf_mtf(f /
// pixel_scale), and the total signal (sum) of a pattern away from the borders
// is conserved. Where the OTF is still non-zero at Nyquist (coarse sampling of
// a sharp PSF), the band-limited kernel rings and can make small negative
// values; the sensor effect clamps negative irradiance to zero photons.
// Throws std::invalid_argument for a wrong image type or invalid options.
void apply_psf(cv::Mat& image, const PsfOptions& options, double pixel_scale = 1.0);

}  // namespace tactres
