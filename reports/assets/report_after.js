  document.querySelectorAll('figure.thumb img').forEach(function (img) {
    img.addEventListener('click', function () { img.parentElement.classList.toggle('enlarged'); });
  });
