window.emaStabDiagram=function(root){
__SYNTHESIS_JS__
var CURVE_LEVELS=__CURVE_LEVELS__,PICK_KEY='__PICK_KEY__';
var out=root.querySelector('pre.picks'), info=root.querySelector('.info');
var count=root.querySelector('.npicks'), cfg=JSON.parse(root.getAttribute('data-diagram'));
var svg=root.querySelector('svg.stab'), NS='http://www.w3.org/2000/svg';
var preview=root.querySelector('[data-pole-preview]'),pvText=preview.querySelector('.pv-text');
var pvPick=preview.querySelector('[data-pick-toggle]'),pvBars=preview.querySelector('.pv-bars');
var pvGeo=preview.querySelector('.pv-geometry'),ring=svg.querySelector('.previewed');
var d=JSON.parse(root.querySelector('script.stab-poles').textContent);
d.fl=Array.prototype.map.call(d.fl,function(c){
 return d.lmin+(c.charCodeAt(0)-CODE0)/CURVE_LEVELS*(d.lmax-d.lmin);});
var lo=d.lo, hi=d.hi, view=[lo,hi], dragged=false, SL=null, current=null;
function num(x){x=+x;if(!isFinite(x))return 'nan';var s=String(x);
 return /[.eEn]/.test(s)?s:s+'.0';}
(function(){
 var g=svg.querySelector('g.diagram-poles'),oi={};
 d.orders.forEach(function(o,k){oi[o]=k;});
 for(var j=0;j<d.f.length;j++){var c=document.createElementNS(NS,'text'),k=d.s[j];
  c.setAttribute('class','pole st-'+k);c.textContent=k;
  c.setAttribute('y',(d.y0-(oi[d.o[j]]+0.5)*d.row).toFixed(1));
  c.setAttribute('data-freq-hz',d.f[j]);c.setAttribute('data-zeta',d.z[j]);
  c.setAttribute('data-order',d.o[j]);c.setAttribute('data-mpc',d.m[j]);
  c.setAttribute('data-group',d.g[j]);c.setAttribute('data-stability',k);
  c.setAttribute('data-stable',k==='s'?'1':'0');g.appendChild(c);}
})();
function poles(){return Array.prototype.slice.call(svg.querySelectorAll('.pole'));}
function isMode(p){return p.dataset.kind==='mode';}
function fHz(p){return +(isMode(p)?p.dataset.xHz:p.dataset.freqHz);}
function xof(f){return d.x0+(f-view[0])/(view[1]-view[0])*d.pw;}
function fof(x){return view[0]+(x-d.x0)/d.pw*(view[1]-view[0]);}
function ticks(a,b){var raw=(b-a)/d.parts,st=d.steps,step=st[st.length-1];
 for(var k=0;k<st.length;k++){if(st[k]>=raw*0.999){step=st[k];break;}}
 var dec=Math.max(0,-Math.floor(Math.log10(step)+1e-9)),t=[];
 for(var i=Math.ceil(a/step-1e-9);i<=Math.floor(b/step+1e-6);i++){t.push((i*step).toFixed(dec));}
 return t;}
function draw(){
 root.setAttribute('data-x-min-hz',view[0]);root.setAttribute('data-x-max-hz',view[1]);
 svg.querySelectorAll('text.pole').forEach(function(c){var f=+c.dataset.freqHz;
  c.setAttribute('x',xof(f).toFixed(1));
  c.style.display=(f<view[0]||f>view[1])?'none':'';});
 svg.querySelectorAll('polygon.pole').forEach(function(p){var f=+p.dataset.xHz,
  cx=xof(f),y=+p.dataset.y,r=5;
  p.setAttribute('points',[cx,y-r,cx+r,y,cx,y+r,cx-r,y].map(function(v){
   return v.toFixed(1);}).join(' '));
  p.style.display=(f<view[0]||f>view[1])?'none':'';});
 if(current){var f=fHz(current);ring.setAttribute('cx',xof(f).toFixed(1));
  ring.setAttribute('cy',isMode(current)?current.dataset.y:current.getAttribute('y'));
  ring.style.display=(f<view[0]||f>view[1])?'none':'';}
 var tg=svg.querySelector('g.ticks');tg.textContent='';
 ticks(view[0],view[1]).forEach(function(t){var e=document.createElementNS(NS,'text'),
  x=xof(+t).toFixed(1);
  e.setAttribute('x',x);e.setAttribute('y',d.y0+14);e.setAttribute('text-anchor','middle');
  e.setAttribute('data-axis-tick','');e.setAttribute('data-axis','frequency');
  e.setAttribute('data-value',t);e.textContent=t;tg.appendChild(e);
  var l=document.createElementNS(NS,'path');l.setAttribute('class','grid');
  l.setAttribute('d','M'+x+' '+(d.y0+4)+'V'+(d.y0-d.ph));tg.appendChild(l);});
 curve(svg.querySelector('[data-frf-overlay]'),d.fl.length?d.fl:null);
 curve(svg.querySelector('[data-synthesis]'),SL);
}
function curve(el,vals){var pts=[];
 if(el&&vals){var n=vals.length,
  a=Math.max(0,Math.floor((view[0]-d.f0)/d.df)),b=Math.min(n-1,Math.ceil((view[1]-d.f0)/d.df));
  for(var k=a;k<=b;k++){pts.push((k===a?'M':'L')+
   Math.min(d.x0+d.pw,Math.max(d.x0,xof(d.f0+k*d.df))).toFixed(1)+' '+
   Math.min(d.y0,Math.max(d.y0-d.oh,d.y0-(vals[k]-d.lmin)/(d.lmax-d.lmin||1)*d.oh)).toFixed(1));}}
 if(el){el.setAttribute('d',pts.join(''));}}
function lambdas(sel){
 var l=sel.map(function(p){var m=isMode(p),
  w=2*Math.PI*fHz(p),z=+(m?p.dataset.zetaFit:p.dataset.zeta);
  return [-z*w-d.sy.wdr,w*Math.sqrt(Math.max(0,1-z*z))];});
 if(cfg.companions.length&&sel.every(isMode)){l=l.concat(cfg.companions);}
 return l.filter(function(x){return isFinite(x[0])&&isFinite(x[1])&&x[1]>0;});}
function resynth(){
 SL=d.sy&&d.sy.n?synthesis(lambdas(poles().filter(function(p){
  return p.classList.contains('selected');}))):null;}
function setView(a,b){var w=Math.max(b-a,(hi-lo)*1e-3);
 w=Math.min(w,hi-lo);if(a<lo){a=lo;}if(a+w>hi){a=hi-w;}view=[a,a+w];draw();}
function zoom(factor,center){var c=center===undefined?(view[0]+view[1])/2:center;
 setView(c-(c-view[0])*factor,c-(c-view[0])*factor+(view[1]-view[0])*factor);}
function svgx(ev){var r=svg.getBoundingClientRect();
 return (ev.clientX-r.left)*svg.viewBox.baseVal.width/r.width;}
root.querySelector('[data-zoom-in]').addEventListener('click',function(){zoom(0.5);});
root.querySelector('[data-zoom-out]').addEventListener('click',function(){zoom(2);});
root.querySelector('[data-zoom-reset]').addEventListener('click',function(){setView(lo,hi);});
svg.addEventListener('wheel',function(ev){ev.preventDefault();
 var x=svgx(ev);if(x<d.x0||x>d.x0+d.pw)return;
 zoom(ev.deltaY<0?0.8:1.25,fof(x));},{passive:false});
var drag=null;
svg.addEventListener('mousedown',function(ev){dragged=false;
 drag={x:svgx(ev),view:view.slice()};});
window.addEventListener('mousemove',function(ev){if(!drag)return;var dx=svgx(ev)-drag.x;
 if(Math.abs(dx)>4){dragged=true;svg.classList.add('dragging');}
 if(dragged){var df=dx/d.pw*(drag.view[1]-drag.view[0]);
  setView(drag.view[0]-df,drag.view[1]-df);}});
window.addEventListener('mouseup',function(){drag=null;svg.classList.remove('dragging');});
resynth();draw();
function text(){
 var sel=poles().filter(function(p){return p.classList.contains('selected');});
 sel.sort(function(a,b){return a.dataset.freqHz-b.dataset.freqHz;});
 var t=['# ema-pipeline picks: `ema-pipeline identify FILE --picks THIS_FILE` fits exactly',
  '# these poles (refinement, LSFD and uncertainty as for automatic modes).',
  '# A pick with `order` is the pole of that model order nearest to freq_hz',
  '# (within 0.1 %); a pick with `pole` (rad/s) is the start pole of a mode the',
  '# automatic selection kept, taken as given.','version = 1','',
  '[diagram]  # the settings that reproduce the stabilization diagram',
  'band_hz = ['+num(cfg.band_hz[0])+', '+num(cfg.band_hz[1])+']',
  'orders = ['+cfg.orders.join(', ')+']','weighting = "'+cfg.weighting+'"'];
 if(cfg.companions.length&&sel.every(isMode)){
  t.push('# poles fitted alongside the picks, not reported: candidates the automatic',
   '# selection refined with its modes and then dropped (rad/s)',
   'companions = ['+cfg.companions.map(function(c){return '['+num(c[0])+', '+num(c[1])+
   ']';}).join(', ')+']');}
 sel.forEach(function(p){
  t.push('','[[pick]]','freq_hz = '+num(p.dataset.freqHz),'zeta = '+num(p.dataset.zeta));
  if(isMode(p)){t.push('pole = ['+num(p.dataset.poleRe)+', '+num(p.dataset.poleIm)+']');}
  else{t.push('order = '+p.dataset.order);}
 });
 out.textContent=t.join('\n')+'\n';
 count.textContent=sel.length;
}
function values(p){
 return 'f = '+fHz(p).toFixed(3)+' Hz, ζ = '+
  (100*(isMode(p)?p.dataset.zetaFit:p.dataset.zeta)).toFixed(3)+
  ' %, MPC = '+(+p.dataset.mpc).toFixed(3);}
function stability(p){var k=p.dataset.stability;return k+' ('+d.stab[k]+')';}
function describe(p){
 return isMode(p)?'kept mode '+p.dataset.mode+': '+values(p):
  'order '+p.dataset.order+': '+values(p)+', '+stability(p);}
function line(cls,txt){var e=document.createElement('p');e.className=cls;
 e.textContent=txt;pvText.appendChild(e);return e;}
function pickState(){var p=current,on=p.classList.contains('selected'),
 what=isMode(p)?'mode':'pole',st=preview.querySelector('.pv-state'),
 other=poles().filter(function(q){return q!==p&&q.classList.contains('selected')&&
  q.dataset.group===p.dataset.group;})[0];
 pvPick.textContent=(on?'Unpick':'Pick')+' this '+what+' ('+PICK_KEY.toUpperCase()+')';
 pvPick.setAttribute('aria-pressed',on?'true':'false');
 st.textContent=on?'Picked: the picks file below fits it.':other?'Not picked; picking it '+
  'moves the pick of its trajectory from '+fHz(other).toFixed(3)+' Hz (one pole a mode).':
  'Not picked.';}
function showPreview(p){
 current=p;window.emaStabActive=root;preview.hidden=false;pvText.textContent='';
 pvBars.textContent='';
 var m=isMode(p),h=line('pv-head',m?describe(p):'order '+p.dataset.order+': '+values(p));
 h.setAttribute('data-preview-freq-hz',m?p.dataset.xHz:p.dataset.freqHz);
 if(m){line('muted','Refined frequency and damping, as the tables give them; stable '+
   (+p.dataset.stableCount?'from order '+p.dataset.stableFirst+' to '+p.dataset.stableLast+
    ' ('+p.dataset.stableCount+' orders)':'at no order of the stored diagram')+
   (p.dataset.foundBy?'; found by: '+p.dataset.foundBy:'')+'.');}
 else{line('pv-stability','Stability: '+stability(p)+'.');}
 line('pv-state','');pickState();draw();
 var sh=m?d.shapes[+p.dataset.mode-1]:null;
 if(pvGeo){pvGeo.hidden=!sh;}
 if(!sh){var q=document.createElement('p');q.className='muted';
  q.textContent=d.noshape||('The shape is known for the kept modes (diamonds): pick '+
   'this pole and fit the picks to see its shape.');pvBars.appendChild(q);return;}
 if(pvGeo){var fig=pvGeo.querySelector('figure.shape-view');
  fig.setAttribute('data-key',+p.dataset.mode-1);
  fig.querySelector('figcaption').textContent='Mode '+p.dataset.mode+': '+
   fHz(p).toFixed(2)+' Hz on the test geometry';
  pvGeo.querySelector('.shape-views').dispatchEvent(new Event('shape-key'));}
 var n=sh.length,W=520,H=120,bw=(W-40)/n,s=document.createElementNS(NS,'svg');
 s.setAttribute('viewBox','0 0 '+W+' '+H);s.setAttribute('data-shape','');
 s.setAttribute('role','img');s.setAttribute('aria-label','real-normalised shape by DOF');
 var z=document.createElementNS(NS,'path');z.setAttribute('d','M30 60H'+(W-10));
 z.setAttribute('stroke','#999');s.appendChild(z);
 var every=Math.max(1,Math.ceil(n*40/(W-40)));
 sh.forEach(function(v,k){var r=document.createElementNS(NS,'rect'),x=30+k*bw;
  r.setAttribute('x',(x+bw*0.15).toFixed(1));r.setAttribute('width',(bw*0.7).toFixed(1));
  r.setAttribute('y',(60-Math.max(v,0)*50).toFixed(1));
  r.setAttribute('height',(Math.abs(v)*50).toFixed(1));r.setAttribute('fill','#1f4e79');
  s.appendChild(r);
  if(k%every===0){var t=document.createElementNS(NS,'text');t.setAttribute('x',
   (x+bw/2).toFixed(1));t.setAttribute('y',H-2);t.setAttribute('text-anchor','middle');
   t.setAttribute('font-size','9');t.textContent=d.dofs[k];s.appendChild(t);}});
 pvBars.appendChild(s);
 var view=Array.prototype.find.call(document.querySelectorAll('figure.shape-view'),
  function(v){return v.dataset.modeShape===p.dataset.mode;});
 if(view){var b=document.createElement('button');b.type='button';
  b.setAttribute('data-show-shape',p.dataset.mode);
  b.textContent='Show its view in the mode shapes section';
  b.addEventListener('click',function(){view.scrollIntoView({block:'center'});
   view.style.outline='3px solid #c00000';
   setTimeout(function(){view.style.outline='';},2500);});
  pvBars.appendChild(b);}
}
function toggle(p){
 if(p.classList.contains('selected')){p.classList.remove('selected');}
 else{poles().forEach(function(q){if(q.dataset.group===p.dataset.group)
   q.classList.remove('selected');});p.classList.add('selected');}
 info.textContent=(p.classList.contains('selected')?'picked ':'unpicked ')+describe(p);
 text();resynth();draw();if(current){pickState();}
}
function target(ev){var p=ev.target.closest?ev.target.closest('.pole'):null;
 return p&&svg.contains(p)?p:null;}
svg.addEventListener('mouseover',function(ev){var p=target(ev);if(!p)return;
 info.textContent=describe(p);
 if(!p.querySelector('title')){var t=document.createElementNS(NS,'title');
  t.textContent=describe(p);p.appendChild(t);}});
svg.addEventListener('click',function(ev){var p=target(ev);
 if(p&&!dragged){showPreview(p);}});
pvPick.addEventListener('click',function(){if(current){toggle(current);}});
document.addEventListener('keydown',function(ev){
 if(window.emaStabActive!==root||!current||ev.ctrlKey||ev.metaKey||ev.altKey||
  (ev.key||'').toLowerCase()!==PICK_KEY)return;
 var e=ev.target;if(e&&(/^(INPUT|TEXTAREA|SELECT)$/.test(e.tagName)||e.isContentEditable))
  return;
 ev.preventDefault();toggle(current);});
root.querySelector('.copy-picks').addEventListener('click',function(){
 var s=out.textContent;
 function fallback(){var a=document.createElement('textarea');a.value=s;
  document.body.appendChild(a);a.select();try{document.execCommand('copy');}catch(e){}
  document.body.removeChild(a);}
 if(navigator.clipboard&&navigator.clipboard.writeText){
  navigator.clipboard.writeText(s).catch(fallback);}else{fallback();}
});
root.querySelector('.download-picks').addEventListener('click',function(){
 var a=document.createElement('a');
 a.href=URL.createObjectURL(new Blob([out.textContent],{type:'application/toml'}));
 a.download=cfg.file;document.body.appendChild(a);a.click();document.body.removeChild(a);
});
text();
};